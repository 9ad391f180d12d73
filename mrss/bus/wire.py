"""The frames the bus carries besides plain `[topic, envelope]` messages.

* Batch: `[topic, envelope, envelope, ...]`, consecutive messages of one publisher on
  one topic, sent together in a burst (see `Publisher`).
* Welcome: the proxy greets each new subscriber with one `[WELCOME]` frame, which tells
  a subscriber it is connected (see `Subscriber.wait_connected`); a direct proxy greets
  with `[WELCOME_DIRECT]` and answers a membership with `[membership topic]`
  (mrss/bus/direct.py).
* Reliable data: `[b"rel.<channel>.msg", topic, envelope, header]`; the middle two frames
  are an ordinary message, `header` is `session (16 bytes), seq, base` where `base` is the
  sender's lowest unacknowledged sequence number.
* Reliable ack: `[b"rel.<channel>.ack.<session hex>", session (16 bytes) + watermark]`,
  the receiver's highest sequence number below which it has everything.
"""

from __future__ import annotations

import re
import struct

from mrss.errors import ConfigError, DecodeError
from mrss.messages import Envelope, decode

WELCOME = b"\x00mrss.welcome"
WELCOME_DIRECT = b"\x00mrss.welcome.direct"  # the direct proxy's (mrss/bus/direct.py)
MEMBER = b"\xfe"  # a membership topic's first byte (direct.py)
MARKER = b"\xff"  # a direct proxy's one subscription to its publishers (direct.py)
# What direct publishers tell the direct proxy (under its marker; mrss/bus/introducer.py).
HELLO, JOINED, BYE = MARKER + b"hello", MARKER + b"joined", MARKER + b"bye"
RELIABLE_PREFIX = b"rel."
SESSION_BYTES = 16
_HEADER = struct.Struct("!16sQQ")
_ACK = struct.Struct("!16sQ")
_CHANNEL = re.compile(r"\A[A-Za-z0-9_-]{1,64}\Z")


def check_channel(channel: str) -> str:
    """A reliable channel name: letters, digits, '_' and '-' (it becomes a topic part)."""
    if not isinstance(channel, str) or not _CHANNEL.match(channel):
        raise ConfigError(f"channel name {channel!r} must match [A-Za-z0-9_-]{{1,64}}",
                          key="channel")
    return channel


def data_topic(channel: str) -> bytes:
    return b"rel.%s.msg" % channel.encode()


def ack_topic(channel: str, session: bytes) -> bytes:
    return b"rel.%s.ack.%s" % (channel.encode(), session.hex().encode())


def pack_header(session: bytes, seq: int, base: int) -> bytes:
    return _HEADER.pack(session, seq, base)


def unpack_header(header: bytes) -> tuple[bytes, int, int]:
    """`(session, seq, base)` of a reliable data frame; DecodeError if malformed."""
    if len(header) != _HEADER.size:
        raise DecodeError(f"reliable header has {len(header)} bytes, not {_HEADER.size}")
    session, seq, base = _HEADER.unpack(header)
    if seq == 0 or base == 0 or base > seq:
        raise DecodeError(f"reliable header has bad numbers seq={seq} base={base}")
    return bytes(session), int(seq), int(base)


def pack_ack(session: bytes, watermark: int) -> bytes:
    return _ACK.pack(session, watermark)


def unpack_ack(payload: bytes) -> tuple[bytes, int]:
    """`(session, watermark)` of an ack frame; DecodeError if malformed."""
    if len(payload) != _ACK.size:
        raise DecodeError(f"ack has {len(payload)} bytes, not {_ACK.size}")
    session, watermark = _ACK.unpack(payload)
    return bytes(session), int(watermark)


def is_answer(frames: list[bytes]) -> bool:
    """Whether a message is a direct proxy's answer to a member's membership."""
    return len(frames) == 1 and frames[0][:1] == MEMBER


def is_ack(topic: bytes) -> bool:
    return topic.startswith(RELIABLE_PREFIX) and b".ack." in topic


def message_frames(frames: list[bytes]) -> list[tuple[bytes, bytes]]:
    """The `(topic, envelope)` pairs in one multipart bus message, not yet decoded.

    A plain message holds one, a publisher's batch `[topic, envelope, ...]` several, a
    reliable data message one (a monitor sees reliable traffic like any other); welcome
    and ack frames hold none. Any other shape raises DecodeError.
    """
    count = len(frames)
    if count >= 2 and not frames[0].startswith(RELIABLE_PREFIX):
        topic = frames[0]
        return [(topic, payload) for payload in frames[1:]]
    if count == 4 and frames[0].startswith(RELIABLE_PREFIX):
        return [(frames[1], frames[2])]
    if (count == 2 and is_ack(frames[0])) or (count == 1 and (
            frames[0] in (WELCOME, WELCOME_DIRECT) or frames[0][:1] == MEMBER)):
        return []
    raise DecodeError(f"unexpected message of {count} frame(s)",
                      topic=_printable(frames[0]) if frames else None)


def decode_frames(frames: list[bytes]) -> Envelope | None:
    """The one message in a plain or reliable data message; None for control frames."""
    pairs = message_frames(frames)
    if len(pairs) > 1:
        raise DecodeError("a batch where one message was expected",
                          topic=_printable(frames[0]))
    return decode(*pairs[0]) if pairs else None


def _printable(topic: bytes) -> str:
    return topic[:80].decode("utf-8", "replace")
