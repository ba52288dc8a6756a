"""How hoprover's kernels are compiled with numba (the lowest layer): the `kernel`
decorator, cache handling and the parallel cold compile (`compiler`), and the opt-in
compiler changes for a faster cold start (`numba_layer`)."""
