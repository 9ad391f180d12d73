"""MAVLink 2 message signing: the key file, the checks, and what is refused.

Rules (the one place they are implemented):
- A key file holds the 32-byte secret as 64 hexadecimal characters (surrounding
  whitespace ignored), e.g. made with ``python -c "import secrets;
  print(secrets.token_hex(32))" > keys/uav1.key``. The key of all zeros is refused (it
  means "signing off" in MAVLink). Paths are relative to the project folder.
- With a key, every outgoing message is signed, and an incoming message is accepted only
  when it is signed with that key and its timestamp is newer than the last accepted one
  of the same stream (link id, system, component), or, for a new stream, at most one
  minute older than ours (the MAVLink signing rules). Unsigned, wrongly signed and
  replayed messages are refused: counted per `Refusal` in a `RejectionLog` ("MAVLink
  message", by connection and refusal: the first of each per `LOG_INTERVAL_S` logged,
  the rest in a summary line with the total once the interval is over, so every
  refusal counted is in the log; never a traceback), and never seen by the link or the
  vehicle.
- The signature is checked before the timestamp is remembered, so a forged message
  with a far-future timestamp cannot lock a stream out (pymavlink remembers it first).
- Unknown message ids cannot be authenticated by pymavlink's decoder: with a key they
  are refused too (as unsigned).
"""

from __future__ import annotations

import enum
import hashlib
import hmac
import logging
import string
import threading
import time
from collections import Counter
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from mrss.edge.rejections import RejectionLog
from mrss.errors import ConfigError

KEY_BYTES = 32
LOG_INTERVAL_S = 10.0
NEW_STREAM_WINDOW = 6_000_000  # 60 s in the signing timestamp's 10 us units
SIGNING_EPOCH = 1420070400     # 1 January 2015, the MAVLink signing epoch
SIGNATURE_INVALID = "Invalid signature"  # pymavlink's refusal reason


class Refusal(enum.Enum):
    """Why an incoming message was refused under signing."""

    UNSIGNED = "unsigned"
    BAD_SIGNATURE = "bad signature"
    REPLAYED = "replayed"


def key_problem(path: Path, shown: str | None = None) -> str | None:
    """Why `path` is not a usable signing key file, or None (`shown`: its name in messages)."""
    name = shown or str(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        return f"cannot read signing key file {name!r}: {exc.strerror or exc}"
    text = raw.strip()
    if len(text) != 2 * KEY_BYTES or not all(chr(c) in string.hexdigits for c in text):
        return (f"signing key file {name!r} must hold {KEY_BYTES} bytes as "
                f"{2 * KEY_BYTES} hexadecimal characters (e.g. the output of python -c "
                "\"import secrets; print(secrets.token_hex(32))\"), "
                f"not {len(text)} bytes of text")
    if not any(bytes.fromhex(text.decode())):
        return f"signing key file {name!r} holds the all-zero key, which means no signing"
    return None


def load_key(path: str | Path, base: Path | None = None, *, key: str = "signing_key") -> bytes:
    """The 32-byte secret of a key file (relative to `base`); ConfigError naming `key`."""
    full = Path(path)
    if base is not None and not full.is_absolute():
        full = base / full
    problem = key_problem(full)
    if problem:
        raise ConfigError(problem, key=key)
    return bytes.fromhex(full.read_bytes().strip().decode())


def signing_timestamp(now: float | None = None) -> int:
    """The signing clock: 10 us units since 2015, as pymavlink and ArduPilot count."""
    seconds = max(time.time() if now is None else now, SIGNING_EPOCH) - SIGNING_EPOCH
    return int(seconds * 100_000)


REFUSED_SUFFIX = "; refused "
HEARTBEAT_REASONS = ("waiting for first heartbeat", "no heartbeat for")


def down_reason(reason: str, totals: dict[str, int], explained: int) -> str | None:
    """A link's down `reason` extended with the refusals (`totals`) when there are more
    than `explained` and the link waits for heartbeats; None to leave it."""
    count = sum(totals.values())
    base = reason.split(REFUSED_SUFFIX)[0]
    if count <= explained or not base.startswith(HEARTBEAT_REASONS):
        return None
    detail = ", ".join(f"{n} {why}" for why, n in totals.items() if n)
    return f"{base}{REFUSED_SUFFIX}{count} messages not signed with this link's key ({detail})"


class SigningParser(mavlink2.MAVLink):  # type: ignore[misc]  # untyped base
    """The ardupilotmega MAVLink 2 codec with the signature checked before the timestamp."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.refusal: Refusal | None = None  # why the last signed message was refused

    def check_signature(self, msgbuf: bytearray, srcSystem: int,  # noqa: N803 (base's names)
                        srcComponent: int) -> bool:
        secret = self.signing.secret_key
        assert secret is not None
        digest = hashlib.sha256(secret + bytes(msgbuf[:-6])).digest()[:6]
        if not hmac.compare_digest(digest, bytes(msgbuf[-6:])):
            self.refusal = Refusal.BAD_SIGNATURE
            return False
        link_id = msgbuf[-13]
        timestamp = int.from_bytes(bytes(msgbuf[-12:-6]), "little")
        stream = (link_id, srcSystem, srcComponent)
        last = self.signing.stream_timestamps.get(stream)
        if (last is not None and timestamp <= last) or \
                (last is None and timestamp + NEW_STREAM_WINDOW < self.signing.timestamp):
            self.refusal = Refusal.REPLAYED
            return False
        self.signing.stream_timestamps[stream] = timestamp
        self.signing.timestamp = max(self.signing.timestamp, timestamp)
        return True


class Signing:
    """One connection's signing: the shared state, the refusal counts and their log."""

    def __init__(self, key: bytes, *, link_id: int, name: str,
                 log: logging.Logger | None = None) -> None:
        if len(key) != KEY_BYTES or not any(key):
            raise ValueError(f"a signing key is {KEY_BYTES} bytes, not all zero")
        self.state = mavlink2.MAVLinkSigning()
        self.state.secret_key = key
        self.state.sign_outgoing = True
        self.state.link_id = link_id
        self.state.timestamp = signing_timestamp()
        self.name = name
        self.log = log or logging.getLogger("mrss.links.signing")
        self.refused: Counter[Refusal] = Counter()
        self._lock = threading.Lock()
        #: Counted in the component's Rejections reports, logged once per interval.
        self.rejections = RejectionLog(self.log, "MAVLink message", interval=LOG_INTERVAL_S)

    def attach(self, mav: Any) -> None:
        """Make `mav` (a pymavlink codec) sign with and check against this state."""
        mav.signing = self.state

    def parser(self) -> SigningParser:
        """A fresh decoder (one UDP datagram's) sharing this signing state."""
        parser = SigningParser(None)
        parser.robust_parsing = True
        self.attach(parser)
        return parser

    def accepts(self, msg: Any, parser: Any) -> bool:
        """Whether a decoded message (or BAD_DATA) may go on; counts and logs refusals."""
        kind = msg.get_type()
        refusal: Refusal | None = None
        if kind == "BAD_DATA" and SIGNATURE_INVALID in str(getattr(msg, "reason", "")):
            refusal = getattr(parser, "refusal", None) or Refusal.UNSIGNED
            if isinstance(parser, SigningParser):
                parser.refusal = None
        elif kind.startswith("UNKNOWN"):
            refusal = Refusal.UNSIGNED  # pymavlink skips the signature of unknown ids
        if refusal is None:
            return True
        self.count(refusal)
        return False

    def count(self, refusal: Refusal) -> None:
        """One message refused: counted by reason, and in the rejection log."""
        with self._lock:
            self.refused[refusal] += 1
        self.rejections.reject(self.name, refusal.value, "signing is on")

    def close(self) -> None:
        """Log the refusals held back so far (the connection closes)."""
        self.rejections.flush()

    def totals(self) -> dict[str, int]:
        """Refusals so far by reason, e.g. {"unsigned": 3, "bad signature": 0, ...}."""
        with self._lock:
            return {r.value: self.refused[r] for r in Refusal}
