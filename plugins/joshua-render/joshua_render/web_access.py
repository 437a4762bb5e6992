"""Who may use the web display: the page's own origin, and on a network address whoever holds its token.

A browser lets any web site open a WebSocket to 127.0.0.1, and the page's controls drive the run (pause, scrub,
drag, the status every viewer reads). So every HTTP and WebSocket request is checked before viser sees it:
- `Host` must name this server (on a loopback address: 127.0.0.1, localhost or ::1 with its port), which stops
  a DNS-rebinding page whose name resolves to 127.0.0.1;
- `Origin`, which browsers send with every WebSocket handshake and cross-site request, must be the page's own
  (`http://` + the Host asked for); `Origin: null` (a sandboxed frame, a file) is refused;
- on an address reachable from the network, the request carries the token printed in the terminal, as
  `?token=...` in the URL (the page then keeps it as a cookie for its scripts and its WebSocket) or that cookie.
A request without `Origin` comes from a program, not a web page, and passes on a loopback address: a program
on this machine can drive the run anyway.

viser takes no such check, so `guarded_serve` puts it in front of the `process_request` viser hands to
websockets' `serve` while the server starts.
"""

from __future__ import annotations

import contextlib
import hmac
import http
import secrets
import sys
import threading
from collections.abc import Callable, Iterator
from http.cookies import CookieError, SimpleCookie
from typing import TYPE_CHECKING, Any
from urllib.parse import parse_qs, urlsplit

if TYPE_CHECKING:
    from websockets.datastructures import Headers

LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")
TOKEN_COOKIE = "joshua_web_token"
TOKEN_PARAMETER = "token"
_STARTING = threading.Lock()  # one server at a time replaces websockets' serve while it starts


class AccessRule:
    """The requests a server on `host:port` answers: its own origin, and the token when it is not loopback-only."""

    def __init__(self, host: str, port: int) -> None:
        self.port = port
        self.loopback = host in LOOPBACK_HOSTS
        self.token = None if self.loopback else secrets.token_urlsafe(24)
        self._warned: set[str] = set()

    def page_url(self, shown_host: str) -> str:
        """The address to open, with the token when one is needed."""
        query = f"?{TOKEN_PARAMETER}={self.token}" if self.token else ""
        return f"http://{shown_host}:{self.port}/{query}"

    def refusal(self, headers: Headers, path: str) -> str | None:
        """Why a request with these headers for `path` is refused, or None when it is the page's own."""
        hosts, origins = headers.get_all("Host"), headers.get_all("Origin")
        if len(hosts) != 1 or len(origins) > 1:
            return "not one Host header, or several Origin headers"
        host = hosts[0]
        if self.loopback and _split_host(host) not in {(name, self.port) for name in LOOPBACK_HOSTS}:
            return f"Host {host!r} is not this server"
        if origins and origins[0] != f"http://{host}":
            return f"Origin {origins[0]!r} is not the page's own"
        if self.token is not None and not self._has_token(headers, path):
            return "no valid token (open the address the terminal printed)"
        return None

    def cookie_for(self, path: str) -> str | None:
        """The Set-Cookie value that keeps a token given in the URL for the page's later requests."""
        if self.token is None or not _token_in_query(path, self.token):
            return None
        return f"{TOKEN_COOKIE}={self.token}; Path=/; HttpOnly; SameSite=Strict"

    def _has_token(self, headers: Headers, path: str) -> bool:
        assert self.token is not None
        if _token_in_query(path, self.token):
            return True
        cookie = SimpleCookie()
        for line in headers.get_all("Cookie"):
            with contextlib.suppress(CookieError):
                cookie.load(line)
        held = cookie.get(TOKEN_COOKIE)
        return held is not None and hmac.compare_digest(held.value.encode(), self.token.encode())

    def warn_once(self, reason: str) -> None:
        """One line on the terminal for each kind of refused request."""
        if reason not in self._warned:
            self._warned.add(reason)
            print(f"joshua: warning: web display: refused a request: {reason}", file=sys.stderr, flush=True)


def _split_host(host: str) -> tuple[str, int]:
    """`name:port` or `[v6]:port` from a Host header as (name, port); port 80 when none is given."""
    parts = urlsplit(f"//{host}")
    try:
        port = parts.port or 80
    except ValueError:
        port = -1
    return (parts.hostname or ""), port


def _token_in_query(path: str, token: str) -> bool:
    given = parse_qs(urlsplit(path).query).get(TOKEN_PARAMETER, [])
    return any(hmac.compare_digest(value.encode(), token.encode()) for value in given)


def _guard(rule: AccessRule, inner: Callable[..., Any] | None) -> Callable[..., Any]:
    """A websockets `process_request` that answers 403 to what `rule` refuses and hands the rest to `inner`."""
    from websockets.datastructures import Headers
    from websockets.http11 import Response

    def process_request(connection: Any, request: Any) -> Any:
        reason = rule.refusal(request.headers, request.path)
        if reason is not None:
            rule.warn_once(reason)
            body = f"Forbidden: {reason}\n".encode()
            headers = Headers({"Content-Type": "text/plain; charset=utf-8", "Content-Length": str(len(body))})
            return Response(http.HTTPStatus.FORBIDDEN, "Forbidden", headers, body)
        response = inner(connection, request) if inner is not None else None
        cookie = rule.cookie_for(request.path)
        if response is not None and cookie is not None:
            response.headers["Set-Cookie"] = cookie
        return response

    return process_request


@contextlib.contextmanager
def guarded_serve(rule: AccessRule) -> Iterator[list[bool]]:
    """While it lasts, websockets' `serve` (which viser's server calls on its own thread as it starts) checks
    every request against `rule`. Yields a list that holds True once a server was started under the guard, so
    that a viser that no longer starts its server this way fails closed instead of serving unguarded."""
    import websockets.asyncio.server as ws_server

    original = ws_server.serve
    guarded: list[bool] = []

    def serve(*args: Any, **kwargs: Any) -> Any:
        kwargs["process_request"] = _guard(rule, kwargs.get("process_request"))
        guarded.append(True)
        return original(*args, **kwargs)

    with _STARTING:
        ws_server.serve = serve  # type: ignore[misc,assignment]
        try:
            yield guarded
        finally:
            ws_server.serve = original  # type: ignore[misc]
