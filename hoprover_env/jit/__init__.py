"""How hoprover's kernels are compiled with numba (the lowest layer): the `kernel`
decorator, cache handling and the parallel cold compile (`compiler`), and the order the
threaded loops read their rows in (`spread`)."""
