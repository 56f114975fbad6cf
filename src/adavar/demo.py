"""Public face of :mod:`adavar.pipeline.demo`:
``import adavar.demo`` works as documented.

The names are defined and documented in :mod:`adavar.pipeline.demo`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.pipeline.demo import (
    GYRO_BANDWIDTH,
    GYRO_BIAS,
    GYRO_LSB,
    GYRO_RATE,
    GYRO_SAMPLES,
    GYRO_TRUE,
    GYRO_UNITS,
    NIST_AVERAGING_FACTORS,
    NIST_MEAN,
    NIST_PUBLISHED,
    NIST_STD,
    PAPER_SEEDS,
    DemoResult,
    GyroDemo,
    NistRow,
    PaperDemo,
    run_demo,
    worker_pool,
)

__all__ = [
    "GYRO_BANDWIDTH",
    "GYRO_BIAS",
    "GYRO_LSB",
    "GYRO_RATE",
    "GYRO_SAMPLES",
    "GYRO_TRUE",
    "GYRO_UNITS",
    "NIST_AVERAGING_FACTORS",
    "NIST_MEAN",
    "NIST_PUBLISHED",
    "NIST_STD",
    "PAPER_SEEDS",
    "DemoResult",
    "GyroDemo",
    "NistRow",
    "PaperDemo",
    "run_demo",
    "worker_pool",
]
