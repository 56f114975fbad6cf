"""adavar: Allan-family statistics, noise-coefficient fits and the adaptive dynamic Allan variance."""

__version__ = "0.1.0"
