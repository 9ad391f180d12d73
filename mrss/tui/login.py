"""The dashboard's login: who the operator is, before anything is shown or sent.

With users configured (`mrss users`, mrss/auth/store.py) `mrss tui` (in a terminal or,
with `--web`, in a browser) opens on `LoginScreen`: a user name and a password or
personal token, checked against the identity store. A good login mints a session
credential (mrss/auth/sessions.py) that goes with every command the dashboard sends
(the bus envelope's `op`, the MQTT commands' `"credential"`); the component that
executes a command checks it and the role (mrss/runtime/operator_guard.py). The
dashboard connects to the bus only after the login; a wrong one says why and stays.
`MRSS_OPERATOR_TOKEN` (a personal token) logs in without the screen.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Vertical
from textual.screen import Screen
from textual.widgets import Input, Static

from mrss.auth.sessions import mint, verify
from mrss.auth.store import AuthError, Identity, OperatorStore
from mrss.errors import ConfigError

if TYPE_CHECKING:
    from mrss.tui.app import MrssApp

TOKEN_ENV = "MRSS_OPERATOR_TOKEN"


@dataclass
class Login:
    """The identity store of the project, and the operator once logged in."""

    store_path: Path
    identity: Identity | None = None
    credential: str = field(default="", repr=False)

    def login(self, name: str, secret: str) -> Identity:
        """Log `name` in with a password or token; AuthError / ConfigError say why not."""
        store = OperatorStore.load(self.store_path)
        identity = store.login(name.strip(), secret)
        self.identity, self.credential = identity, mint(store, identity)
        return identity

    def login_with_token(self, token: str) -> Identity:
        """Log in with a personal token alone (`MRSS_OPERATOR_TOKEN`)."""
        store = OperatorStore.load(self.store_path)
        identity = verify(store, token.strip())
        self.identity, self.credential = identity, mint(store, identity)
        return identity


class LoginScreen(Screen[Identity]):
    """User and password (or token); Enter logs in, Ctrl+Q leaves."""

    DEFAULT_CSS = """
    LoginScreen { align: center middle; }
    #login { width: 60; height: auto; border: round $accent; padding: 1 2; }
    #login-error { color: $error; height: auto; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("ctrl+q", "app.quit", "Leave", priority=True)]
    AUTO_FOCUS = "#login-user"  # before the first frame: keys typed at once land there

    def __init__(self, login: Login, project: str) -> None:
        super().__init__()
        self.login = login
        self.project = project

    def compose(self) -> ComposeResult:
        with Vertical(id="login"):
            yield Static(f"MRSS {self.project}: log in (mrss users {self.project} list "
                         "shows who may)")
            yield Input(placeholder="user", id="login-user")
            yield Input(placeholder="password or token", password=True, id="login-secret")
            yield Static("", id="login-error")

    def on_input_submitted(self, event: Input.Submitted) -> None:
        user = self.query_one("#login-user", Input)
        secret = self.query_one("#login-secret", Input)
        if event.input is user:
            self.set_focus(secret)
            self.query_one("#login-error", Static).update(
                f"the password or token of {user.value.strip()}, then Enter")
            return
        try:
            identity = self.login.login(user.value, secret.value)
        except (AuthError, ConfigError) as exc:
            secret.value = ""
            secret.focus()
            self.query_one("#login-error", Static).update(f"not logged in: {exc}")
            return
        self.dismiss(identity)


def log_in_first(app: MrssApp, start: Callable[[], None]) -> None:
    """`start` the dashboard at once when the project has no users, else once its
    operator logged in (at once with a token given); the operator's session credential
    then goes with everything the dashboard sends, and the title names them."""
    login = app.login
    if login is None:
        start()
        return

    def logged_in(identity: Identity | None) -> None:
        if identity is None:
            return
        app.link.operator = login.credential
        if app.mission is not None:
            app.mission.credential = login.credential
        app.title = f"{app.title} · {identity}"
        start()

    if login.identity is not None:
        logged_in(login.identity)
    else:
        app.push_screen(LoginScreen(login, app.project), logged_in)
