#!/usr/bin/env python3
"""Starvation check of `terrabake serve` on loopback: what an ordinary client
gets while others hold the server's connections or flood its bake queue.

    tests/load/run_starve.py [terrabake_executable] [flood_requests]

1. 500 connections that send nothing and 16 that send their request head one
   byte a second, then one ordinary GET of a cached tile: its time.
2. `flood_requests` (default 2000) concurrent requests for distinct tiles that
   are not made yet (an on-demand layer), while one client keeps asking for
   cached tiles: the cached tiles' latency, and how fast the flood is answered
   (200 after a bake, 503 at once, or a refused connection).
3. A POST announcing a 256 MB body, with a few bytes of it: the status, its
   time, and the server's memory before and after.

Prints one line per figure; exits 1 when the ordinary GET of (1) got no answer.
Every loop is bounded in count and time.
"""
import math
import os
import selectors
import socket
import subprocess
import sys
import tempfile
import threading
import time

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXE = sys.argv[1] if len(sys.argv) > 1 else os.path.join(REPO, "build/src/app/terrabake")
FLOOD = int(sys.argv[2]) if len(sys.argv) > 2 else 2000
LIMIT_S = 30.0


def connect(port):
    s = socket.create_connection(("127.0.0.1", port), timeout=LIMIT_S)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


def request(path, extra=""):
    return f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n{extra}Connection: close\r\n\r\n".encode()


def get(port, path, limit=LIMIT_S):
    """Status and seconds of one GET; status -1 when there was no answer in time."""
    start = time.monotonic()
    try:
        with connect(port) as s:
            s.settimeout(limit)
            s.sendall(request(path))
            data = s.recv(64)
            status = int(data[9:12]) if data.startswith(b"HTTP/1.") else -1
    except OSError:
        status = -1
    return status, time.monotonic() - start


def rss_kib(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def tiles_at(bounds, zoom):
    """Web-mercator tiles covering bounds [w, s, e, n] at `zoom`."""
    def xy(lon, lat):
        n = 2 ** zoom
        x = int((lon + 180) / 360 * n)
        lat_r = math.radians(lat)
        y = int((1 - math.log(math.tan(lat_r) + 1 / math.cos(lat_r)) / math.pi) / 2 * n)
        return x, y
    (x0, y0), (x1, y1) = xy(bounds[0], bounds[3]), xy(bounds[2], bounds[1])
    return [(zoom, x, y) for x in range(x0, x1 + 1) for y in range(y0, y1 + 1)]


def percentile(values, p):
    values = sorted(values)
    return values[min(len(values) - 1, int(len(values) * p))] if values else float("nan")


def idle_and_slow(port, cached_path):
    idle = [connect(port) for _ in range(500)]
    slow = [connect(port) for _ in range(16)]
    head = request(cached_path)
    stop = threading.Event()

    def trickle():
        for i in range(len(head)):  # one byte a second, for as long as the check lasts
            if stop.wait(1.0):
                return
            for s in slow:
                try:
                    s.send(head[i:i + 1])
                except OSError:
                    pass

    sender = threading.Thread(target=trickle)
    sender.start()
    time.sleep(1.5)
    status, took = get(port, cached_path)
    stop.set()
    sender.join()
    for s in idle + slow:
        s.close()
    print(f"idle+slow-header: 500 idle, 16 at 1 byte/s: ordinary GET -> {status} in {took * 1000:.0f} ms")
    return status == 200


def flood(port, flood_paths, cached_paths):
    sel = selectors.DefaultSelector()
    start = time.monotonic()
    outcomes = {}
    for i, path in enumerate(flood_paths):
        try:
            s = socket.socket()
            s.setblocking(False)
            s.connect_ex(("127.0.0.1", port))
            sel.register(s, selectors.EVENT_WRITE, (i, path, b""))
        except OSError:
            outcomes[i] = ("connect failed", 0.0)
    latencies = []
    stop = threading.Event()

    def cached_client():
        k = 0
        while not stop.is_set() and k < 100000:
            status, took = get(port, cached_paths[k % len(cached_paths)], limit=LIMIT_S)
            latencies.append((status, took))
            k += 1

    client = threading.Thread(target=cached_client)
    client.start()
    deadline = start + LIMIT_S
    while sel.get_map() and time.monotonic() < deadline:
        for key, events in sel.select(timeout=0.5):
            s = key.fileobj
            i, path, got = key.data
            try:
                if events & selectors.EVENT_WRITE:
                    s.send(request(path))
                    sel.modify(s, selectors.EVENT_READ, (i, path, b""))
                    continue
                data = s.recv(4096)
            except OSError as e:
                outcomes[i] = ("reset" if got == b"" else got[9:12].decode(), time.monotonic() - start)
                sel.unregister(s)
                s.close()
                continue
            got += data
            if len(got) >= 12 or not data:
                outcomes[i] = (got[9:12].decode() if len(got) >= 12 else "closed", time.monotonic() - start)
                sel.unregister(s)
                s.close()
            else:
                sel.modify(s, selectors.EVENT_READ, (i, path, got))
    unanswered = len(sel.get_map())
    for key in list(sel.get_map().values()):
        key.fileobj.close()
    stop.set()
    client.join()
    counts = {}
    for status, _ in outcomes.values():
        counts[status] = counts.get(status, 0) + 1
    refused_times = [t for status, t in outcomes.values() if status in ("503", "reset", "closed")]
    ok = [t for status, t in latencies if status == 200]
    print(f"flood: {len(flood_paths)} distinct unbaked tiles at once: {dict(sorted(counts.items()))}, "
          f"{unanswered} unanswered after {LIMIT_S:.0f} s; refusals answered within "
          f"p50 {percentile(refused_times, 0.5) * 1000:.0f} ms, p99 {percentile(refused_times, 0.99) * 1000:.0f} ms")
    print(f"flood: cached tiles meanwhile: {len(ok)} of {len(latencies)} answered 200, "
          f"p50 {percentile(ok, 0.5) * 1000:.1f} ms, p99 {percentile(ok, 0.99) * 1000:.1f} ms, "
          f"max {max(ok, default=float('nan')) * 1000:.1f} ms")


def big_body(port, pid):
    before = rss_kib(pid)
    start = time.monotonic()
    status = -1
    try:
        with connect(port) as s:
            s.settimeout(LIMIT_S)
            s.sendall(b"POST /sample/tilejson.json HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                      b"Content-Length: 268435456\r\n\r\n" + b"x" * 64)
            data = s.recv(64)
            status = int(data[9:12]) if data.startswith(b"HTTP/1.") else -1
    except OSError:
        pass
    took = time.monotonic() - start
    time.sleep(0.2)
    print(f"256 MB body announced: {status} in {took * 1000:.0f} ms, "
          f"server RSS {before // 1024} -> {rss_kib(pid) // 1024} MiB")


def main():
    work = tempfile.mkdtemp(prefix="terrabake-starve.")
    tiles = os.path.join(work, "tiles")
    subprocess.run([EXE, "tile", "--config", os.path.join(REPO, "config/sample.yaml"), "--out", tiles,
                    "--backend", "cpu"], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(os.path.join(work, "flood.yaml"), "w") as f:
        f.write(f"dem: {REPO}/tests/data/sample_dem.tif\noutput:\n  layer: flood\n"
                "tiling:\n  zoom: [9, 17]\n  tile_size: 64\nbake:\n  backend: cpu\n  workers: 1\n")
    with open(os.path.join(work, "serve.yaml"), "w") as f:
        f.write(f"tiles: {tiles}\nlayers: [{work}/flood.yaml]\n")
    server = subprocess.Popen([EXE, "serve", "--config", os.path.join(work, "serve.yaml"), "--port", "0"],
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        line = server.stdout.readline()
        port = int(line.rsplit(":", 1)[1].strip().rstrip("/"))
        cached = sorted("/" + os.path.relpath(os.path.join(d, n), tiles)
                        for d, _, names in os.walk(os.path.join(tiles, "sample")) for n in names if n.endswith(".png"))
        import json
        bounds = json.load(open(os.path.join(tiles, "flood", "tilejson.json")))["bounds"]
        zoom_tiles = [t for z in (16, 17) for t in tiles_at(bounds, z)][:FLOOD]
        flood_paths = [f"/flood/{z}/{x}/{y}.png" for z, x, y in zoom_tiles]
        answered = idle_and_slow(port, cached[0])
        time.sleep(1)
        flood(port, flood_paths, cached)
        big_body(port, server.pid)
    finally:
        server.terminate()
        try:
            server.wait(timeout=LIMIT_S)
        except subprocess.TimeoutExpired:
            server.kill()
        subprocess.run(["rm", "-rf", work])
    sys.exit(0 if answered else 1)


if __name__ == "__main__":
    main()
