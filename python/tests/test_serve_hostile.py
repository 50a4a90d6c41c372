"""`udvr serve` against hostile and careless clients (issue 34, items 1-9): every limit is enforced
before the work or the memory is spent, slow or vanished clients hold nothing others need, and
pages of other origins cannot drive it. Each test names what it measured before the fix."""
import json
import socket
import threading
import time
import urllib.parse

import pytest

from serve_util import Server, host_port, make_inputs, raw_exchange, rss_mib


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    return make_inputs(tmp_path_factory.mktemp("serve_hostile"))


@pytest.fixture(scope="module")
def server(inputs):
    s = Server(inputs.model, "--tf", inputs.tf, "--read-timeout", "4")
    yield s
    s.stop()


def timed(fn, *args, **kw):
    start = time.monotonic()
    out = fn(*args, **kw)
    return out, time.monotonic() - start


def head(server, path, *headers, method="GET", body=b""):
    """A request's bytes with Host (the server's own) and more header lines."""
    host, port = host_port(server)
    lines = [f"{method} {path} HTTP/1.1", f"Host: {host}:{port}", *headers]
    return ("\r\n".join(lines) + "\r\n\r\n").encode() + body


# ---- 1: byte ranges ------------------------------------------------------------------------------
def test_many_ranges_get_one_body(server):
    """Before: 206 and a multipart body holding the image once per range (500 x 16 KiB here; 1 GB
    per 60 ranges at 2048^2). Now ranges are not served: 200 and the image once."""
    ranges = "bytes=" + ",".join(["0-"] * 500)
    status, answer = raw_exchange(server, head(server, "/api/render?size=64x64&format=rgba",
                                               f"Range: {ranges}", "Connection: close"))
    assert status == 200, answer[:200]
    headers, body = answer.split(b"\r\n\r\n", 1)
    assert len(body) == 64 * 64 * 4 and b"multipart" not in headers


# ---- 2: probes are bounded and take their turn ---------------------------------------------------
def test_probe_is_bounded_and_queued(server):
    """Before: /api/probe?size=1x1&step=1e-8 classified every sample of one ray (15 s, 4.8 GB).
    Now the ray's samples are capped before any work, and probes take a turn of the gate."""
    (status, _, body), seconds = timed(server.get,
                                       "/api/probe?x=0&y=0&size=1x1&step=1e-8&model=mean")
    assert status == 400 and "step" in json.loads(body)["error"] and seconds < 3
    assert server.get("/api/probe?x=0&y=0&size=5000x5000")[0] == 400  # render's size limit
    before = server.json("/api/status")["completed"]
    assert server.get("/api/probe?model=gaussian&size=64x64&x=32&y=30")[0] == 200
    assert server.json("/api/status")["completed"] >= before + 2  # the pick and the probe


# ---- 3: body limits for every transfer encoding --------------------------------------------------
def send_until_answered(server, request_head, chunk, limit):
    """Send the head, then `chunk` again and again (at most `limit` bytes) until the server
    answers; (status, bytes of body sent)."""
    with socket.create_connection(host_port(server), timeout=10) as s:
        s.sendall(request_head)
        sent = 0
        s.setblocking(False)
        answer = b""
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            try:
                answer += s.recv(1 << 16)
                if b"\r\n\r\n" in answer:
                    break
            except BlockingIOError:
                pass
            except OSError:
                break
            if sent < limit:
                try:
                    sent += s.send(chunk)
                except BlockingIOError:
                    time.sleep(0.001)
                except OSError:
                    pass
            else:
                time.sleep(0.01)
    assert answer.startswith(b"HTTP/1.1 "), answer[:100]
    return int(answer.split(b" ", 2)[1]), sent


def test_chunked_body_stops_at_the_limit(server):
    """Before: a chunked 1 GiB POST to /api/tf was read whole (3.2 GB RSS), then 400. Now it is
    answered 413 after about 1 MiB, and the server's memory does not grow."""
    rss = rss_mib(server)
    data = b"x" * 65536
    chunk = b"10000\r\n" + data + b"\r\n"
    status, sent = send_until_answered(
        server, head(server, "/api/tf", "Content-Type: application/json",
                     "Transfer-Encoding: chunked", method="POST"), chunk, 1 << 30)
    assert status == 413 and sent < 64 << 20
    # Tiny chunks (6 bytes of framing for each byte) and a chunk-size line that never ends.
    status, _ = send_until_answered(
        server, head(server, "/api/tf", "Transfer-Encoding: chunked", method="POST"),
        b"1\r\nx\r\n" * 10000, 256 << 20)
    assert status in (400, 413)
    status, _ = send_until_answered(
        server, head(server, "/api/tf", "Transfer-Encoding: chunked", method="POST"),
        b"1" * 65536, 256 << 20)
    assert status in (400, 413)
    assert rss_mib(server) < rss + 64
    assert server.alive()


@pytest.mark.parametrize("headers,status", [
    (["Content-Length: 1099511627776"], 413),
    (["Transfer-Encoding: gzip"], 501),
    (["Content-Length: 10", "Content-Encoding: gzip"], 415),
    ([], 411),
    (["Content-Length: 12", "Transfer-Encoding: chunked"], 400),
    (["Content-Length: -1"], 400),
])
def test_bodies_refused_before_reading(server, headers, status):
    (answer_status, answer), seconds = timed(
        raw_exchange, server, head(server, "/api/tf", *headers, method="POST"))
    assert answer_status == status, answer[:200]
    assert json.loads(answer.split(b"\r\n\r\n", 1)[1])["error"] and seconds < 3


def test_header_limits(server):
    """Before: header lines were read without end (httplib checks a line's length once it has
    ended, and not the number of lines). Now the head is at most 64 KiB: 431 (or httplib's 400
    when the limit falls inside the header lines)."""
    rss = rss_mib(server)
    lines = [f"X-Pad-{k}: {'a' * 1000}" for k in range(2000)]  # 2 MB of header lines
    status, _ = raw_exchange(server, head(server, "/api/state", *lines))
    assert status in (400, 431)
    host, port = host_port(server)
    endless = b"GET /api/state?" + b"a" * (8 << 20)  # an 8 MB request line, never ended
    status, _ = raw_exchange(server, endless)
    assert status in (414, 431)
    assert rss_mib(server) < rss + 32 and server.alive()


# ---- 4: slow clients -----------------------------------------------------------------------------
def test_slow_clients_do_not_starve_the_others(server):
    """Before: 30 connections trickling a header line a second held the 24 request threads, and
    /api/state timed out until they closed. Now each connection has its own thread, the head has
    a deadline (--read-timeout, 4 s here: 408), and /api/state answers at once."""
    socks = []
    for _ in range(30):
        s = socket.create_connection(host_port(server), timeout=10)
        s.sendall(b"GET /api/state HTTP/1.1\r\n")
        socks.append(s)
    stop = threading.Event()

    def trickle():
        k = 0
        while not stop.is_set():
            for s in socks:
                try:
                    s.sendall(f"X-Slow-{k}: 1\r\n".encode())
                except OSError:
                    pass
            k += 1
            stop.wait(1.0)

    t = threading.Thread(target=trickle)
    t.start()
    try:
        worst = 0.0
        for _ in range(8):
            (status, _, _), seconds = timed(server.get, "/api/state")
            assert status == 200
            worst = max(worst, seconds)
            time.sleep(0.5)
        assert worst < 1.0
        # The read timeout ends them: 408 within it (plus a second of slack).
        start = time.monotonic()
        socks[0].settimeout(8)
        answer = socks[0].recv(4096)
        assert answer.startswith(b"HTTP/1.1 408") and time.monotonic() - start < 6
    finally:
        stop.set()
        t.join()
        for s in socks:
            s.close()


def test_connection_floods_make_room(inputs):
    """More idle connections than --max-connections: the one that waited longest is closed, and a
    real request is still answered."""
    s = Server(inputs.model, "--tf", inputs.tf, "--max-connections", "8")
    try:
        idle = [socket.create_connection(host_port(s), timeout=10) for _ in range(20)]
        time.sleep(0.2)
        (status, _, _), seconds = timed(s.get, "/api/state")
        assert status == 200 and seconds < 1.0
        for c in idle:
            c.close()
    finally:
        s.stop()


# ---- 5: TF2 rasterisation ------------------------------------------------------------------------
def test_tf2_work_is_bounded_and_queued(inputs):
    """Before: one band of 5,000 points at 1024^2 (30 KB) rasterised for 26 s on a request thread.
    Now the work (points x widget terms) is capped before parsing's cost is paid, and a posted TF2
    is rasterised in a turn of the gate."""
    from test_serve_api import TANGLE_TF2
    s = Server(inputs.model, "--tf2", TANGLE_TF2)
    try:
        band = {"domain": [-7, 35, 0, 60], "resolution": [1024, 1024], "widgets": [
            {"type": "band", "points": [[-7 + 42 * k / 5000, 60 * k / 5000] for k in range(5000)],
             "half_width": [0.5, 0.5], "rgba": [1, 0, 0, 0.5]}]}
        (status, _, body), seconds = timed(s.get, "/api/tf2", data=json.dumps(band).encode(),
                                           method="POST")
        assert status == 400 and "band" in json.loads(body)["error"] and seconds < 3
        before = s.json("/api/status")["completed"]
        band["widgets"][0]["points"] = band["widgets"][0]["points"][::50]
        band["resolution"] = [256, 256]
        assert s.get("/api/tf2", data=json.dumps(band).encode(), method="POST")[0] == 200
        assert s.get("/api/histogram2d?bins=32")[0] == 200
        assert s.json("/api/status")["completed"] == before + 2
    finally:
        s.stop()


# ---- 6: abandoned renders ------------------------------------------------------------------------
def test_an_abandoned_render_is_cancelled(server):
    """Before: gmm-mc 512^2 with 1000 realizations ran on after its client had gone, and a 64^2
    render waited ~19 s. Now the server sees the client go and cancels the frame."""
    q = urllib.parse.urlencode({"model": "gmm-mc", "size": "512x512", "realizations": 1000,
                                "channel": "abandon"})
    s = socket.create_connection(host_port(server), timeout=10)
    s.sendall(head(server, "/api/render?" + q))
    deadline = time.monotonic() + 10
    while server.json("/api/status")["running"] == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    s.close()
    abandoned = server.json("/api/status")["abandoned"]
    (status, _, _), seconds = timed(server.get, "/api/render?size=64x64&channel=other")
    assert status == 200 and seconds < 2.0
    assert server.json("/api/status")["abandoned"] >= max(abandoned, 1)


# ---- 7, 8: channels and their sequences ----------------------------------------------------------
def test_channels_are_evicted(server):
    """Before: the 65th channel name got 400 until a restart. Now the least recently used idle
    channel makes room."""
    for k in range(70):
        status, _, body = server.get(f"/api/render?size=8x8&channel=c{k}")
        assert status == 200, (k, body[:200])
    stats = server.json("/api/status")
    assert stats["channels"] <= 64 and stats["evicted"] >= 6


def test_sequences_are_per_page_load(server):
    """Before: seq=2^64-1 once made every later seq on that channel 409 (a reloaded page got no
    frames). Now seq is at most 2^53-1, and each page load's channels (page=TOKEN) count their own
    seq."""
    status, _, body = server.get("/api/render?size=8x8&channel=main&seq=18446744073709551615")
    assert status == 400 and "seq" in json.loads(body)["error"]
    top = 2 ** 53 - 1
    assert server.get(f"/api/render?size=8x8&page=load1&seq={top}")[0] == 200
    assert server.get("/api/render?size=8x8&page=load1&seq=1")[0] == 409  # ordered in the page
    assert server.get("/api/render?size=8x8&page=load2&seq=1")[0] == 200  # a new page load
    assert server.get("/api/render?size=8x8&page=load2&seq=2")[0] == 200


# ---- 9: Origin and Host --------------------------------------------------------------------------
def test_other_origins_and_hosts_are_refused(server, inputs):
    """Before: a POST from any web page (Origin: http://evil.example, text/plain) changed the TF,
    and Host: evil.example (DNS rebinding) was served. Now both get 403 before any work."""
    before = server.get("/api/tf")[2]
    host, port = host_port(server)
    evil = json.dumps([{"RGBPoints": [0, 1, 0, 0, 1, 1, 0, 0], "Points": [0, 1, 0.5, 0]}])
    for headers in (["Origin: http://evil.example", "Content-Type: text/plain"],
                    ["Origin: null"], [f"Origin: http://{host}:{port + 1}"],
                    ["Sec-Fetch-Site: cross-site"], ["Sec-Fetch-Site: same-site"]):
        status, answer = raw_exchange(server, head(
            server, "/api/tf", *headers, f"Content-Length: {len(evil)}", method="POST",
            body=evil.encode()))
        assert status == 403, (headers, answer[:200])
    for name in ("evil.example", "evil.example:80", "127.0.0.1.evil.example", "10.0.0.1", ""):
        status, _ = raw_exchange(server, f"GET /api/state HTTP/1.1\r\nHost: {name}\r\n\r\n"
                                 .encode())
        assert status == 403, name
    assert server.get("/api/tf")[2] == before
    # The server's own page: same origin, loopback names.
    for name in (f"{host}:{port}", f"localhost:{port}", f"[::1]:{port}", "127.1.2.3"):
        status, _ = raw_exchange(server, f"GET /api/state HTTP/1.1\r\nHost: {name}\r\n"
                                 f"Origin: http://{name}\r\nSec-Fetch-Site: same-origin\r\n"
                                 "Connection: close\r\n\r\n".encode())
        assert status == 200, name
    s = Server(inputs.model, "--tf", inputs.tf, "--allow-host", "viewer.example")
    try:
        ok = "GET /api/state HTTP/1.1\r\nHost: viewer.example\r\nOrigin: https://viewer.example" \
             "\r\nConnection: close\r\n\r\n"
        assert raw_exchange(s, ok.encode())[0] == 200
        assert raw_exchange(s, b"GET /api/state HTTP/1.1\r\nHost: other.example\r\n\r\n")[0] == 403
    finally:
        s.stop()
