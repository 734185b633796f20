"""MJPEG over HTTP: the multipart reader of the Q24 driver (thesis 2.2). No ROS.

An IP camera such as the Mobotix Q24 serves its live view as one endless HTTP response of
type ``multipart/x-mixed-replace; boundary=B`` ("server push"): each part is a delimiter
line ``--B``, part headers (``Content-Type: image/jpeg``, ``Content-Length: N`` when the
camera sends it), a blank line and the JPEG bytes. The HTTP request and response are
left to the standard library (``urllib.request`` / ``http.client``, see ``open_stream``);
this module parses only what comes after the response headers, from any readable binary
stream (a socket's response, a file holding a recording, ``io.BytesIO`` in tests).

``read_frames`` yields each part's bytes untouched with the time its first byte was read.
Tolerated: the boundary parameter quoted or not, given with or without the leading
``--`` (and the body's delimiter lines with or without it), parts with or without
``Content-Length`` (without it, the part ends at the next delimiter line). Errors are
``MjpegError`` subclasses that name the problem: ``HttpStatusError`` (e.g. 404),
``NotMultipartError`` (an HTML page), ``ConnectError``, ``StreamStalled`` (read timeout),
``TruncatedPart`` (the stream ended inside a part). A stream that ends between parts
simply ends the iteration.
"""
import base64
import email.message
import socket
import time
import urllib.error
import urllib.parse
import urllib.request
from typing import BinaryIO, Callable, Dict, Iterator, NamedTuple, Optional, Tuple

MAX_LINE_BYTES = 64 * 1024        # one header or delimiter line; longer: not MJPEG
MAX_HEADER_LINES = 64             # part headers before the blank line
MAX_PART_BYTES = 32 * 1024 * 1024  # one frame; a 1024 x 768 JPEG is ~50..300 kB


class MjpegError(Exception):
    """Anything that stops an MJPEG stream; the message names the problem."""


class ConnectError(MjpegError):
    """No HTTP response at all (refused, unreachable, connect timeout)."""


class HttpStatusError(MjpegError):
    """The server answered with an HTTP error status (404, 401, 500...)."""

    def __init__(self, message: str, status: int):
        super().__init__(message)
        self.status = status


class NotMultipartError(MjpegError):
    """The response is not a multipart stream (e.g. an HTML page or a single JPEG)."""


class StreamStalled(MjpegError):
    """No byte arrived within the read timeout."""


class TruncatedPart(MjpegError):
    """The stream ended (or broke) inside a part: its frame is incomplete."""


class ProtocolError(MjpegError):
    """Bytes that are not a multipart stream (no delimiter, a header line too long)."""


class Frame(NamedTuple):
    data: bytes            # the part's body (a JPEG), untouched
    monotonic_s: float     # time.monotonic() when the part's first byte was read
    wall_s: float          # time.time() at the same moment
    headers: Dict[str, str]  # the part's headers, names lower-case


def parse_boundary(content_type: str) -> bytes:
    """The boundary of a ``multipart/x-mixed-replace`` Content-Type, without a leading
    ``--`` (some cameras put it into the parameter), quotes removed.
    NotMultipartError for any other type or a missing boundary."""
    msg = email.message.Message()
    msg["content-type"] = content_type or ""
    kind = msg.get_content_type()
    if not kind.startswith("multipart/"):
        raise NotMultipartError("not an MJPEG stream: Content-Type %r (expected "
                                "multipart/x-mixed-replace)" % (content_type,))
    boundary = msg.get_param("boundary")
    if not boundary or not isinstance(boundary, str):
        raise NotMultipartError("multipart Content-Type %r has no boundary"
                                % (content_type,))
    boundary = boundary.strip()
    if boundary.startswith("--"):
        boundary = boundary[2:]
    if not boundary:
        raise NotMultipartError("empty boundary in Content-Type %r" % (content_type,))
    return boundary.encode("latin-1")


def split_credentials(url: str) -> Tuple[str, Optional[str]]:
    """(the URL without ``user:password@``, a Basic ``Authorization`` header value or
    None). The Q24's ``/control/`` pages need a user; urllib does not take credentials
    from the URL itself."""
    parts = urllib.parse.urlsplit(url)
    if parts.username is None:
        return url, None
    netloc = parts.hostname or ""
    if ":" in netloc:
        netloc = "[%s]" % netloc  # an IPv6 literal
    if parts.port is not None:
        netloc += ":%d" % parts.port
    user = urllib.parse.unquote(parts.username)
    password = urllib.parse.unquote(parts.password or "")
    token = base64.b64encode(("%s:%s" % (user, password)).encode("utf-8")).decode("ascii")
    return urllib.parse.urlunsplit(parts._replace(netloc=netloc)), "Basic " + token


def redact(url: str) -> str:
    """The URL as it may be logged: a password replaced by ``***``."""
    parts = urllib.parse.urlsplit(url)
    if parts.password is None:
        return url
    netloc = parts.netloc.rsplit("@", 1)
    return urllib.parse.urlunsplit(
        parts._replace(netloc="%s:***@%s" % (parts.username, netloc[-1])))


def open_stream(url: str, timeout_s: float) -> Tuple[BinaryIO, bytes]:
    """GET ``url`` with urllib (``timeout_s``: connect and every read) and return the open
    response and its multipart boundary. The caller closes the response. Raises
    HttpStatusError, NotMultipartError (the response is closed) or ConnectError."""
    clean, auth = split_credentials(url)
    shown = redact(url)
    request = urllib.request.Request(clean, headers={"Accept": "multipart/x-mixed-replace"})
    if auth is not None:
        request.add_header("Authorization", auth)
    try:
        response = urllib.request.urlopen(request, timeout=timeout_s)  # noqa: S310
    except urllib.error.HTTPError as exc:
        exc.close()
        raise HttpStatusError("%s answered HTTP %d %s" % (shown, exc.code, exc.reason),
                              exc.code) from exc
    except urllib.error.URLError as exc:
        raise ConnectError("cannot connect to %s: %s" % (shown, exc.reason)) from exc
    except (OSError, ValueError) as exc:  # socket.timeout, a bad URL, reset on connect
        raise ConnectError("cannot connect to %s: %s" % (shown, exc)) from exc
    try:
        boundary = parse_boundary(response.headers.get("Content-Type", ""))
    except NotMultipartError as exc:
        response.close()
        raise NotMultipartError("%s: %s" % (shown, exc)) from exc
    return response, boundary


class _Reader:
    """Line and block reads on a binary stream, with timeouts and EOF made errors."""

    def __init__(self, stream: BinaryIO, timeout_s: Optional[float]):
        self.stream = stream
        self.timeout_s = timeout_s

    def _call(self, fn: Callable[..., bytes], arg: int) -> bytes:
        try:
            return fn(arg)
        except socket.timeout as exc:
            raise StreamStalled("no data for %s s (read timeout)"
                                % ("?" if self.timeout_s is None else "%.1f"
                                   % self.timeout_s)) from exc
        except OSError as exc:  # reset by the peer, network down
            raise ConnectError("connection broken: %s" % exc) from exc

    def line(self) -> bytes:
        return self._call(self.stream.readline, MAX_LINE_BYTES)

    def block(self, n: int) -> bytes:
        """Up to ``n`` bytes, fewer only at the end of the stream."""
        chunks, left = [], n
        while left > 0:
            chunk = self._call(self.stream.read, left)
            if not chunk:
                break
            chunks.append(chunk)
            left -= len(chunk)
        return b"".join(chunks)


def _is_delimiter(line: bytes, boundary: bytes) -> Optional[bool]:
    """None: not a delimiter line; False: ``--B`` (or ``B``); True: the close ``--B--``."""
    text = line.rstrip(b"\r\n").rstrip(b" \t")
    if text.startswith(b"--"):
        text = text[2:]
    if text == boundary:
        return False
    if text == boundary + b"--":
        return True
    return None


def read_frames(stream: BinaryIO, content_type: str, timeout_s: Optional[float] = None,
                clock: Callable[[], float] = time.monotonic,
                wall_clock: Callable[[], float] = time.time) -> Iterator[Frame]:
    """Yield the frames of a multipart stream whose response had ``content_type``
    (``timeout_s`` only names the read timeout in StreamStalled's message; the stream's
    own timeout raises it). Ends when the stream ends between parts or at the close
    delimiter; raises MjpegError subclasses otherwise (see the module doc)."""
    boundary = parse_boundary(content_type)
    reader = _Reader(stream, timeout_s)
    need_delimiter = True  # the preamble, or a part read by its length, comes first
    while True:
        if need_delimiter and _skip_to_delimiter(reader, boundary):
            return
        frame, close, need_delimiter = _read_part(reader, boundary, clock, wall_clock)
        if frame is not None:
            yield frame
        if close:
            return


def _read_part(reader: _Reader, boundary: bytes, clock: Callable[[], float],
               wall_clock: Callable[[], float]) -> Tuple[Optional[Frame], bool, bool]:
    """One part after its delimiter line: (the frame or None at a clean end, whether
    the stream is over, whether the next delimiter line is still to be read). A part
    with Content-Length is returned as soon as its bytes are in, not when the next
    part begins: one frame period less lag."""
    headers: Dict[str, str] = {}
    first: Optional[Tuple[float, float]] = None
    for _ in range(MAX_HEADER_LINES + 1):
        line = reader.line()
        if first is None:
            first = (clock(), wall_clock())
        if not line:
            if headers:
                raise TruncatedPart("stream ended inside the part headers")
            return None, True, False  # a delimiter and then the end: nothing lost
        if len(line) >= MAX_LINE_BYTES and not line.endswith(b"\n"):
            raise ProtocolError("part header line longer than %d bytes" % MAX_LINE_BYTES)
        if not line.strip():
            break
        name, sep, value = line.decode("latin-1").partition(":")
        if sep:
            headers[name.strip().lower()] = value.strip()
    else:
        raise ProtocolError("more than %d part header lines" % MAX_HEADER_LINES)
    assert first is not None
    length_text = headers.get("content-length")
    if length_text is not None:
        try:
            length = int(length_text)
        except ValueError:
            length = -1
        if not 0 <= length <= MAX_PART_BYTES:
            raise ProtocolError("bad part Content-Length %r" % length_text)
        data = reader.block(length)
        if len(data) < length:
            raise TruncatedPart("stream ended inside a frame: %d of %d bytes"
                                % (len(data), length))
        return Frame(data, first[0], first[1], headers), False, True
    data, close = _read_to_delimiter(reader, boundary)
    return Frame(data, first[0], first[1], headers), close, False


def _skip_to_delimiter(reader: _Reader, boundary: bytes) -> bool:
    """Skip the preamble, or the CRLF (and any junk) after a part read by its length, up
    to the next delimiter line; True when the stream is over (close delimiter or end)."""
    skipped = 0
    while True:
        line = reader.line()
        if not line:
            return True
        close = _is_delimiter(line, boundary)
        if close is not None:
            return close
        skipped += len(line)
        if skipped > MAX_PART_BYTES:
            raise ProtocolError("no multipart delimiter %r in %d bytes"
                                % (boundary.decode("latin-1"), skipped))


def _read_to_delimiter(reader: _Reader, boundary: bytes) -> Tuple[bytes, bool]:
    """A part without Content-Length: every line up to the next delimiter line (which
    must start a line), minus the line break before it."""
    chunks = []
    size = 0
    at_line_start = True
    while True:
        line = reader.line()
        if not line:
            raise TruncatedPart("stream ended inside a frame (no Content-Length) after "
                                "%d bytes" % size)
        if at_line_start:
            close = _is_delimiter(line, boundary)
            if close is not None:
                break
        chunks.append(line)
        size += len(line)
        if size > MAX_PART_BYTES:
            raise ProtocolError("part without Content-Length longer than %d bytes"
                                % MAX_PART_BYTES)
        at_line_start = line.endswith(b"\n")
    data = b"".join(chunks)
    if data.endswith(b"\r\n"):
        data = data[:-2]
    elif data.endswith(b"\n"):
        data = data[:-1]
    return data, close


def iter_url(url: str, timeout_s: float) -> Iterator[Frame]:
    """Open ``url`` and yield its frames; the response is closed when the iteration ends
    (also on an error or when the generator is closed)."""
    response, _ = open_stream(url, timeout_s)
    try:
        yield from read_frames(response, response.headers.get("Content-Type", ""),
                               timeout_s)
    finally:
        response.close()
