"""Exceptions raised by shieldnav. Every one names the argument, file or field at fault."""


class ShieldnavError(Exception):
    """Base class of shieldnav's errors."""


class InvalidArgumentError(ShieldnavError, ValueError):
    """An argument is malformed: NaN or inf, wrong shape or dtype, out of its domain."""


class SolverError(ShieldnavError, RuntimeError):
    """A numerical solver failed for a reason other than infeasibility."""


class MapFileError(ShieldnavError, ValueError):
    """A map, image or scenario file is missing or malformed; the message names file and field."""
