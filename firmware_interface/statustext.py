"""STATUSTEXT's chunking, both ways: MAVLink carries 50 characters a message, and a longer text goes as chunks that
share one `id` (id 0: a text in one piece), the last one shorter than 50, as PX4 sends them."""

from __future__ import annotations

from pymavlink.dialects.v20.common import MAVLink_statustext_message

STATUSTEXT_CHUNK = 50  # characters in one STATUSTEXT
STATUSTEXT_MAX_CHUNKS = 8  # a text still unfinished after this many chunks is taken as it stands


def text_chunks(text: str) -> list[str]:
    """`text` in the pieces its STATUSTEXT messages carry. MAVLink's receiver takes a chunk with a null character
    as the last, so a chunked text whose length is a multiple of 50 ends with an empty chunk."""
    chunks = [text[i:i + STATUSTEXT_CHUNK] for i in range(0, len(text), STATUSTEXT_CHUNK)] or [""]
    if len(chunks) > 1 and len(chunks[-1]) == STATUSTEXT_CHUNK:
        chunks.append("")
    return chunks


class StatusTextJoiner:
    """The whole texts of a stream of STATUSTEXT messages."""

    def __init__(self) -> None:
        self._parts: dict[int, list[str]] = {}  # the chunks so far of each unfinished text, by its id

    def join(self, msg: MAVLink_statustext_message) -> str | None:
        """The whole text once `msg` finishes one, None while more chunks are to come."""
        if msg.id == 0:
            return msg.text.strip()
        parts = self._parts.setdefault(msg.id, [])
        parts.append(msg.text)
        if len(msg.text) == STATUSTEXT_CHUNK and len(parts) < STATUSTEXT_MAX_CHUNKS:
            return None
        del self._parts[msg.id]
        return "".join(parts).strip()
