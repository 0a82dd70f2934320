"""The exceptions of qm_mesh: one base class, subclasses by who is responsible."""


class QmError(Exception):
    """Base class of every error qm_mesh raises (a bug in qm itself raises it plain)."""


class DataError(QmError, ValueError):
    """The data is wrong: not a .qm file, a corrupt one, a malformed mesh file,
    or a mesh that cannot be made semi-regular."""


class TruncatedError(DataError):
    """The bytes end inside the header or base mesh of a .qm file (or inside
    a mesh file): more bytes would help. A cut after the base mesh is not an
    error; it decodes to a coarser mesh."""


class LimitError(QmError):
    """The work would exceed a limit: memory (``max_memory``), samples, or the
    32-bit indices of qm's meshes. Checked before anything is allocated."""


class ParameterError(QmError, ValueError):
    """A parameter is out of range or an array has the wrong shape or dtype."""


class FileError(QmError, OSError):
    """Reading or writing a file failed (missing, unreadable, disk full)."""
