"""Helpers for the `udvr serve` tests: small inputs, a server on a free port, PNG pixels."""
import io
import json
import pathlib
import subprocess
import urllib.error
import urllib.request

import numpy as np
import pytest

from conftest import ROOT, UDVR_BINARY, run_ok

TANGLE_TF = ROOT / "data" / "tf" / "tangle.json"


class Inputs:
    """A 32³ tangle, its 12-member ensemble's model (q = 8, K = 4) and the tangle TF."""


def make_inputs(d):
    p = Inputs()
    p.dir = pathlib.Path(d)
    p.truth = p.dir / "tangle.vti"
    p.model = p.dir / "model.vti"
    p.tf = p.dir / "tf.json"
    p.tf.write_text(TANGLE_TF.read_text())
    run_ok("generate", "tangle", "--dims", "32", "-o", p.truth)
    run_ok("perturb", p.truth, "--members", "12", "--seed", "2", "-o", p.dir / "ens.nc")
    run_ok("build", p.dir / "ens.nc", "-o", p.model)
    return p


class Server:
    """`udvr serve ARGS --port 0`, its URL read from the first line it prints."""

    def __init__(self, *args):
        if not UDVR_BINARY.is_file():
            pytest.skip(f"udvr binary not built at {UDVR_BINARY}")
        self.proc = subprocess.Popen(
            [str(UDVR_BINARY), "serve", *map(str, args), "--port", "0"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)
        line = self.proc.stdout.readline()
        if not line.startswith("udvr serve: http://"):
            self.stop()
            raise RuntimeError(f"udvr serve did not start: {line!r} {self.proc.stderr.read()}")
        self.url = line.split()[2].rstrip("/")

    def get(self, path, data=None, method=None):
        """(status, headers, body bytes) of a request; 4xx/5xx do not raise."""
        # JSON bodies as the page sends them (httplib caps form-encoded bodies at 8 KiB).
        headers = {"Content-Type": "application/json"} if data is not None else {}
        req = urllib.request.Request(self.url + path, data=data, method=method, headers=headers)
        try:
            with urllib.request.urlopen(req, timeout=60) as r:
                return r.status, r.headers, r.read()
        except urllib.error.HTTPError as e:
            return e.code, e.headers, e.read()

    def json(self, path, **kw):
        status, _, body = self.get(path, **kw)
        assert status == 200, f"{path}: {status} {body[:300]!r}"
        return json.loads(body)

    def alive(self):
        return self.proc.poll() is None and self.get("/api/status")[0] == 200

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc.stdout.close()
        self.proc.stderr.close()


def png_pixels(data):
    """RGBA uint8 (H, W, 4) of PNG bytes (or a path)."""
    from PIL import Image
    if isinstance(data, (str, pathlib.Path)):
        data = pathlib.Path(data).read_bytes()
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGBA"))


def cli_render(inputs, out, *flags, model_file=None):
    """`udvr render` of the model (or model_file) with `flags`; its PNG's pixels."""
    run_ok("render", model_file or inputs.model, *flags, "-o", out)
    return png_pixels(out)


def cli_probe(model_file, tf, model, point, tf_flag="--tf", *flags):
    """`udvr probe --json` at index point (floats, written so they read back exactly); tf_flag
    "--tf2" for a 2D TF; more `flags` (--second FILE)."""
    text = ",".join(repr(float(v)) for v in point)
    return json.loads(run_ok("probe", model_file, "--point", text, "--model", model, tf_flag, tf,
                             *flags, "--json").stdout)


def tf2_raster(widget_file, out):
    """The raster `udvr tf2 WIDGETS -o out.npy` writes: (H, W, 4) float64, row j from the
    smallest y."""
    run_ok("tf2", widget_file, "-o", out)
    return np.load(out).astype(np.float64)


def tf2_at(raster, domain, x, y):
    """(r, g, b, a) of a TF2 raster at (x, y): bilinear between its points, clamped outside the
    domain (docs/formats.md)."""
    h, w, _ = raster.shape

    def locate(v, lo, hi, n):
        s = (v - lo) / (hi - lo) * (n - 1)
        if not s > 0:
            return 0, 0.0
        if s >= n - 1:
            return n - 2, 1.0
        i = min(int(s), n - 2)
        return i, s - i

    i, fx = locate(x, domain[0], domain[1], w)
    j, fy = locate(y, domain[2], domain[3], h)
    below = raster[j, i] + fx * (raster[j, i + 1] - raster[j, i])
    above = raster[j + 1, i] + fx * (raster[j + 1, i + 1] - raster[j + 1, i])
    return below + fy * (above - below)


def host_port(server):
    """(host, port) of a Server's URL."""
    host, port = server.url.split("//", 1)[1].rsplit(":", 1)
    return host, int(port)


def raw_exchange(server, data, timeout=10.0):
    """Send `data` (bytes) on a new connection and read until the server closes it (or
    `timeout`); (status or None, the whole answer)."""
    import socket
    with socket.create_connection(host_port(server), timeout=timeout) as s:
        try:
            s.sendall(data)
        except OSError:
            pass
        answer = b""
        try:
            while chunk := s.recv(1 << 16):
                answer += chunk
        except OSError:
            pass
    status = int(answer.split(b" ", 2)[1]) if answer.startswith(b"HTTP/1.1 ") else None
    return status, answer


def rss_mib(server):
    """The server process's resident memory, MiB (Linux)."""
    for line in pathlib.Path(f"/proc/{server.proc.pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")
