"""The core layer: errors, settings, units, durations, the noise terms, taus, the
registry of statistics, result classes, atomic outputs, CSV tables, data sets."""
