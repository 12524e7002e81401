"""The bench's channels as foxglove-sdk channels of one context: the recording and the live Foxglove server
log the same topics, the JSON ones with their JSON Schema and Foxglove's views with Foxglove's protobuf schemas."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping

import foxglove

from hil.channels import TOPIC_PREFIX, json_schema, schema_name
from hil.outputs.foxglove_messages import FOXGLOVE_TOPICS


def json_channels(context: foxglove.Context, names: Iterable[str]) -> dict[str, foxglove.Channel]:
    """channel name (e.g. "state") -> its `hil/...` JSON channel."""
    return {name: foxglove.Channel(TOPIC_PREFIX + name, message_encoding="json", context=context,
                                   schema=foxglove.Schema(name=schema_name(name), encoding="jsonschema",
                                                          data=json_schema(name)))
            for name in names}


def view_channels(context: foxglove.Context) -> dict[str, foxglove.Channel]:
    """Foxglove topic (e.g. "foxglove/tf") -> its protobuf channel."""
    return {topic: foxglove.Channel(topic, message_encoding="protobuf", context=context, schema=kind.get_schema())
            for topic, kind in FOXGLOVE_TOPICS.items()}


LogBytes = Callable[[bytes, int], None]  # (serialised message, log time in ns)


def byte_loggers(channels: Mapping[str, foxglove.Channel]) -> dict[str, LogBytes]:
    """Each channel's Rust `log` for bytes, without `Channel.log`'s Python type dispatch (~3 us a call, and the
    bench logs ~17 messages a step)."""
    return {name: channel.base.log for name, channel in channels.items()}
