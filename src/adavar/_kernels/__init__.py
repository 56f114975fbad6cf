"""Building blocks of the compiled (numba) kernels, shared by the modules that use them."""
