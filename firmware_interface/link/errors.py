"""Errors a link raises: a bad connection string, and a link that went away."""


class LinkError(RuntimeError):
    """The link could not be opened (bad connection string, port busy, nothing listening)."""


class LinkLost(LinkError):
    """An open link went away: USB unplugged, pty closed, TCP reset. `reason` says which."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason
