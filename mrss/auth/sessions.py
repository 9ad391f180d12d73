"""Session credentials: an operator's identity, carried with every command they send.

A dashboard logs its operator in against the identity store (password or personal
token) and mints a session credential: `s1:<user>:<expiry>:<nonce>:<mac>`, the MAC an
HMAC-SHA256 of the rest under the store's session key. It travels with each command
(the bus envelope's `op`, an MQTT command's `"credential"`, HTTP `Authorization:
Bearer`). The component that executes the command verifies it (`verify`): a valid MAC,
not expired, and a user that is still in the store, not expired, with the role taken
from the store *now* (a user removed or demoted loses their rights at once, whatever
their dashboard holds). A personal token is accepted the same way.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
import time

from mrss.auth.store import TOKEN_PREFIX, AuthError, Identity, OperatorStore

PREFIX = "s1"
CREDENTIAL_KEY = "credential"  # an MQTT operator command's key for it
DEFAULT_LIFETIME = 12 * 3600.0  # a shift
MAX_LENGTH = 256


def mint(store: OperatorStore, identity: Identity, *, lifetime: float = DEFAULT_LIFETIME,
         now: float | None = None) -> str:
    """A session credential of `identity`, valid for `lifetime` seconds."""
    expiry = int((now if now is not None else time.time()) + lifetime)
    text = f"{PREFIX}:{identity.name}:{expiry}:{secrets.token_hex(8)}"
    return f"{text}:{_mac(store, text)}"


def verify(store: OperatorStore, credential: str, *, now: float | None = None) -> Identity:
    """The identity `credential` (a session credential or a personal token) proves;
    AuthError saying why not."""
    if not credential:
        raise AuthError("no credential (log in first)")
    if len(credential) > MAX_LENGTH:
        raise AuthError("a credential too long to be one")
    if credential.startswith(TOKEN_PREFIX):
        return store.by_token(credential)
    parts = credential.split(":")
    if len(parts) != 5 or parts[0] != PREFIX or not parts[2].isdigit():
        raise AuthError("not a session credential")
    text, mac = ":".join(parts[:4]), parts[4]
    if not hmac.compare_digest(mac, _mac(store, text)):
        raise AuthError(f"a session credential of {parts[1]!r} not signed by this "
                        "project's store")
    if int(parts[2]) <= (now if now is not None else time.time()):
        raise AuthError(f"the session of {parts[1]!r} expired (log in again)")
    user = store.user(parts[1])
    return Identity(user.name, user.role)


def claimed_user(credential: str) -> str:
    """The user a credential names, unverified (for a log line), or ""."""
    parts = credential.split(":")
    return parts[1] if len(parts) == 5 and parts[0] == PREFIX else ""


def _mac(store: OperatorStore, text: str) -> str:
    return hmac.new(store.key, text.encode(), hashlib.sha256).hexdigest()
