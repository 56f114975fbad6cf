"""Reading sensor and clock records from the files people actually have.

:func:`read_record` reads one or several channels of a record, with its sampling rate and
(when the file has one) its time base, from:

=================================  ============  ==========================================
file                               ``kind``      needs
=================================  ============  ==========================================
``.csv .tsv .txt .dat``            "csv"         nothing (pandas' C parser if installed)
``.phd .frd`` (Stable32)           "stable32"    nothing
``.npy``                           "npy"         nothing (memory-mapped)
``.npz``                           "npz"         nothing (uncompressed members memory-mapped)
``.h5 .hdf5 .he5``                 "hdf5"        h5py
``.parquet .pq``                   "parquet"     pyarrow
ROS 2 bag folder (or its           "ros2"        rosbags (sqlite3 or MCAP storage)
``.db3`` / ``.mcap`` file)
ROS 1 ``.bag``                     "ros1"        rosbags
=================================  ============  ==========================================

Nothing is guessed silently: the sampling rate comes from a time column (or time stamps)
or is declared with ``rate``; a numeric time column is in seconds unless its name carries
a unit (``t_ms``, ``time [us]``, ``stamp_ns``) or ``time_format`` says otherwise, and one
that could as well be in another unit (a median step of more than 1, values past the year
5000 in seconds) is an error asking for the unit, as is a ``time_format`` contradicting the
unit in the name; the time column is never analysed as a channel (unless
``time_column="none"``); the rate is the nominal one the stamps bear out exactly
(``1.7e9 + k / 200`` s: 200 Hz), else their mean regular interval; units
the format declares (ROS bags, HDF5 attributes) are checked against the user's
(:meth:`Record.units_of`); every step taken (rows dropped, gaps split or filled, samples
interpolated) is listed in :attr:`Record.meta` so a result can be reproduced.

Every problem with the input raises :class:`adavar.core.errors.AdavarInputError` with a
one-line message that names the problem, where it is, and the way out.

The package, one module per format plus the shared parts (each one imports only the
modules before it; h5py, pyarrow and rosbags are imported when a file needs them):

====================  =====================================================================
module                holds
====================  =====================================================================
``errors``            one-line error messages, optional packages (``require``)
``lazy``              when HDF5 / Parquet columns are read piece by piece (``LAZY_BYTES``)
``table``             the columns of a file, the time column and its unit, the channels
``record``            :class:`Record`, NaN and gap policies, the rate from the time stamps
``textscan``          text files streamed in blocks: binary checks, pandas or NumPy parsing
``text``              CSV / TSV / whitespace text files: delimiter, decimal comma, header
``stable32``          Stable32 ``.phd`` / ``.frd`` files
``npy``               ``.npy`` and ``.npz`` files (memory-mapped)
``hdf5``              HDF5 files
``parquet``           Parquet files
``rosbag``            ROS 1 and ROS 2 bags (IMU messages)
``dispatch``          :func:`read_record`: checks the options, chooses the reader by suffix
====================  =====================================================================
"""

from adavar.readers.dispatch import SUFFIXES, read_record
from adavar.readers.lazy import LAZY_BYTES as LAZY_BYTES
from adavar.readers.record import GAP_POLICIES, NAN_POLICIES, Record
from adavar.readers.stable32 import file_data_type
from adavar.readers.table import TIME_FORMATS
from adavar.readers.textscan import COMMENT_PREFIXES as COMMENT_PREFIXES

__all__ = [
    "GAP_POLICIES",
    "NAN_POLICIES",
    "SUFFIXES",
    "TIME_FORMATS",
    "Record",
    "file_data_type",
    "read_record",
]
