"""blockqc: quality inspection of satellite image blocks adjusted without ground control."""

__version__ = "0.1.0"
