"""The dynamic Allan variance: windows, the surface, the kurtosis and the adaptive
controller, ICI, events, the online (streamed) adaptive window, surface fits."""
