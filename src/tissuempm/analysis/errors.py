"""The error raised for bad wound-analysis input (a missing run, a frame out of range, an unknown body)."""


class AnalysisError(ValueError):
    """Bad input to the wound analysis; the message names the file, field or value and what is valid."""
