"""Host names checked before anything starts: a name that does not resolve is bad input, found at once,
not a connection that fails later."""

from __future__ import annotations

import socket


def unresolved(host: str) -> str | None:
    """Why `host` cannot be resolved to an address, or None when it can."""
    try:
        socket.getaddrinfo(host.strip("[]"), None)
    except (socket.gaierror, UnicodeError) as exc:
        return f"cannot resolve host {host!r}: {getattr(exc, 'strerror', None) or exc}"
    return None
