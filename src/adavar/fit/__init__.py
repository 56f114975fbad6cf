"""The noise-coefficient fits: IEEE-952 GLS/WLS of one curve, stacks of curves,
power laws."""
