"""How hoprover's kernels are compiled with numba (the lowest layer): the `kernel`
decorator, cache handling and the parallel cold compile (`compiler`), the order the
threaded loops read their rows in (`spread`), and `run_threaded`, which runs them
leaving the caller's OpenMP settings alone (`threads`)."""
