"""The one base class for errors a user can fix (bad file, unreachable instrument...).

The command line prints these as one clear message and exits non-zero, without a
traceback; anything else is a bug and keeps its traceback.
"""


class UserError(Exception):
    """An error caused by input or bench state, with a message that names the cause."""
