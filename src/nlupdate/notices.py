"""What a user should hear about but that does not stop the work.

Library code reports such things (a UFF file converted from accelerance to receptance,
the leftover of a killed run cleaned up) with ``warnings.warn(message, NlupdateWarning)``;
the CLI prints each as one line, ``nlupdate: warning: …``, and Python callers can turn
them into errors or silence them with the ``warnings`` module.
"""


class NlupdateWarning(UserWarning):
    """A notice about the user's input or output, shown once per occurrence."""
