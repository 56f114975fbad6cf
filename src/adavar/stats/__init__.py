"""The whole-record statistics: the Allan family, the Theo and total families,
time error, noise identification, EDF, streamed records, gaps, cornered hats."""
