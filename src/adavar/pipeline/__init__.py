"""One file end to end (the commands' analysis), batches, the demonstration,
precompiling the kernels."""
