"""The exception classes of cadinterp: one per status of cadinterp_status.h, under cadinterp.Error.

Each class carries its status code (`status`) and name (`status_name`); the message is the C ABI's
(cadinterp_open_error, cadinterp_workspace_error, cadinterp_builder_error). Classes that mean
"bad input" also derive from the matching built-in (ValueError, OSError, MemoryError,
LookupError), so that generic handlers catch them too.
"""


class Error(Exception):
    """A call of the C ABI failed; `status` is its cadinterp_status code."""

    status = None
    status_name = None

    def __init__(self, message="", status=None):
        super().__init__(message)
        if status is not None and status != type(self).status:
            self.status = status  # a code this package does not know (a newer library)


class FormatError(Error):
    """The bytes are not a valid asset (the format errors, CADINTERP_E_BAD_MAGIC..CORRUPT_BLOB)."""


# (class name, code, bases, status suffix and description): the table of cadinterp_status.h.
_TABLE = [
    ("InvalidArgumentError", 1, (Error, ValueError), "INVALID_ARGUMENT",
     "An argument the C ABI refuses (an index out of range, a bad option...)."),
    ("OutOfMemoryError", 2, (Error, MemoryError), "OUT_OF_MEMORY", "Out of memory."),
    ("IoError", 3, (Error, OSError), "IO", "The file cannot be opened, mapped, read or written."),
    ("BadMagicError", 4, (FormatError,), "BAD_MAGIC", "Not a cadinterp asset."),
    ("UnsupportedVersionError", 5, (FormatError,), "UNSUPPORTED_VERSION",
     "Another format major version, or a newer minor one."),
    ("TruncatedError", 6, (FormatError,), "TRUNCATED", "The file is shorter than its header says."),
    ("CorruptIndexError", 7, (FormatError,), "CORRUPT_INDEX", "The index fails verification."),
    ("ChecksumError", 8, (FormatError,), "CHECKSUM", "Stored bytes differ from their checksum."),
    ("OutOfRangeError", 9, (FormatError,), "OUT_OF_RANGE", "A blob lies outside the file."),
    ("LimitError", 10, (FormatError,), "LIMIT", "A count exceeds the reader's limits."),
    ("CorruptBlobError", 11, (FormatError,), "CORRUPT_BLOB",
     "Mesh data fails to decode or holds invalid values."),
    ("OutsideDomainError", 12, (Error, ValueError), "OUTSIDE_DOMAIN",
     "x is outside the parameter box, or not finite."),
    ("InfeasibleError", 13, (Error,), "INFEASIBLE",
     "x lies where the model could not be built (or no element could be built)."),
    ("InternalError", 14, (Error,), "INTERNAL", "A bug in cadinterp: please report the message."),
    ("NotFoundError", 15, (Error, LookupError), "NOT_FOUND", "No field of that name."),
    ("CancelledError", 16, (Error,), "CANCELLED", "The build was cancelled."),
    ("StoreMismatchError", 17, (Error,), "STORE_MISMATCH",
     "The sample store belongs to another host, identity or parameter box."),
]

_BY_STATUS = {}
for _name, _code, _bases, _suffix, _doc in _TABLE:
    _cls = type(_name, _bases, {"__doc__": _doc, "__module__": "cadinterp", "status": _code,
                                "status_name": "CADINTERP_E_" + _suffix})
    globals()[_name] = _cls
    _BY_STATUS[_code] = _cls
Error.__module__ = FormatError.__module__ = "cadinterp"
del _name, _code, _bases, _suffix, _doc, _cls

__all__ = ["Error", "FormatError"] + [row[0] for row in _TABLE]


def error_class(status):
    """The class of a status code (Error for a code this package does not know)."""
    return _BY_STATUS.get(status, Error)
