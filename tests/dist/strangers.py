#!/usr/bin/env python3
"""Strangers at rank 0's two store ports (dist_strangers.sh): for each port, connections that
close at once, present a wrong token, send garbage or an HTTP request, stop mid-greeting, or send
nothing until the server drops them; then a flood of 40 connections. Prints one line per stranger
the server should name, "STORE SOURCE_PORT REASON", and "flood STORE COUNT" per flood.
Exits 1 when the server answers a stranger in a way it should not (keeps a silent one open, or
lets a wrong token in).
Usage: strangers.py GROUP_STORE_PORT HEARTBEATS_STORE_PORT"""
import socket
import struct
import sys
import time

GREETING = b"f16race-store-v1"
STORES = (("group's", int(sys.argv[1])), ("heartbeats'", int(sys.argv[2])))


def connect(port):
    s = socket.create_connection(("127.0.0.1", port), timeout=10)
    return s, s.getsockname()[1]


def closed_within(s, seconds):
    """Reads until the server closes `s`; the seconds it took, or None if it did not."""
    start = time.monotonic()
    s.settimeout(seconds)
    try:
        while s.recv(4096):
            pass
    except socket.timeout:
        return None
    except ConnectionResetError:
        pass
    return time.monotonic() - start


def strangers(store, port, report):
    silent, src = connect(port)  # first: the server drops it after its greeting timeout (5 s)
    report(store, src, "none presented within 5 s")
    s, src = connect(port)
    s.close()
    report(store, src, "closed before sending one")
    s, src = connect(port)
    s.sendall(struct.pack("<I", len(GREETING) + 24) + GREETING + b"not-the-group-token-1234")
    answer = s.recv(5)
    if answer != struct.pack("<IB", 1, 2) or closed_within(s, 5) is None:
        sys.exit(f"{store} store: a wrong token got {answer!r} and an open connection")
    report(store, src, "a wrong token")
    s, src = connect(port)
    s.sendall(bytes((i * 97 + 13) % 256 for i in range(200)))
    report(store, src, "bytes that are not an f16race store greeting")
    closed_within(s, 5)
    s, src = connect(port)
    s.sendall(b"GET / HTTP/1.1\r\nHost: localhost\r\n\r\n")
    report(store, src, "bytes that are not an f16race store greeting")
    closed_within(s, 5)
    s, src = connect(port)
    s.sendall(struct.pack("<I", len(GREETING) + 30) + GREETING[:8])
    time.sleep(0.3)
    s.close()
    report(store, src, "closed in the middle of its greeting")
    return silent


def main():
    lines = []
    report = lambda store, src, why: lines.append(f"{store} {src} {why}")
    silent = [strangers(store, port, report) for store, port in STORES]
    for s in silent:
        took = closed_within(s, 8)
        if took is None:
            sys.exit("a silent connection was still open after 8 s")
    for store, port in STORES:
        flood = [connect(port)[0] for _ in range(40)]
        time.sleep(0.5)
        for s in flood:
            s.close()
        lines.append(f"flood {store} {len(flood)}")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
