"""STATUSTEXT's chunks through real MAVLink bytes: the emulator's chunking and the bench's joining against the
common.xml rules (id 0: the only chunk; otherwise chunks of one id, the one holding a null character the last)."""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import common

from firmware_interface.statustext import StatusTextJoiner, text_chunks


def on_the_wire(text: str, text_id: int) -> list[common.MAVLink_statustext_message]:
    """The text's STATUSTEXT messages, packed and parsed back by pymavlink."""
    sender, receiver = common.MAVLink(None, 1, 1), common.MAVLink(None, 255, 0)
    chunks = text_chunks(text)
    messages = []
    for seq, chunk in enumerate(chunks):
        msg = common.MAVLink_statustext_message(6, chunk.encode().ljust(50, b"\0"), text_id if len(chunks) > 1 else 0,
                                                seq)
        messages.append(receiver.decode(bytearray(msg.pack(sender))))
    return messages


@pytest.mark.parametrize("length", [0, 10, 50, 51, 100, 120, 150])
def test_a_text_of_any_length_comes_back_whole_once_its_last_chunk_arrives(length):
    text = "".join(chr(ord("a") + i % 26) for i in range(length))
    messages = on_the_wire(text, text_id=7)
    joiner = StatusTextJoiner()
    assert [joiner.join(m) for m in messages[:-1]] == [None] * (len(messages) - 1)
    assert joiner.join(messages[-1]) == text
    if length <= 50:
        assert [m.id for m in messages] == [0]  # one piece
    else:  # the last chunk holds a null character (common.xml: it ends the text), every earlier one is full
        assert len(messages[-1].text) < 50 and all(len(m.text) == 50 for m in messages[:-1])
        assert [(m.id, m.chunk_seq) for m in messages] == [(7, seq) for seq in range(length // 50 + 1)]


def test_two_texts_chunked_side_by_side_are_joined_by_their_ids():
    first, second = "x" * 60, "y" * 70
    a, b = on_the_wire(first, text_id=1), on_the_wire(second, text_id=2)
    joiner = StatusTextJoiner()
    assert [joiner.join(m) for m in (a[0], b[0], b[1], a[1])] == [None, None, second, first]
