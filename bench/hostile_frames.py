"""Benchmark: what the total frame decoder costs, on ordinary frames and on the worst ones.

`fleet_common.wire.codec.decode` checks size, nesting and numbers before and while
`json` reads (fleet_common.limits.loads_frame). This times it on a typical drive frame
against a bare `json.loads` of the same bytes, and on the worst frames a peer can send
within the 64 KB limit: 30,000 nested `[`, 64 KB of brackets inside strings (the depth
scan's slow path), a 400-digit number, 64 KB of 30-digit numbers. Best of --repeat runs.

    .venv/bin/python bench/hostile_frames.py [--repeat 5]
"""
from __future__ import annotations

import argparse
import json
import os
import timeit

from fleet_common.wire import DriveToPosition, RemoteProtocolError
from fleet_common.wire.codec import decode, encode

FRAMES = {
    "30,000 nested [": b"[" * 30000,
    "64 KB of [ in strings": b'["' + b"[" * 65000 + b'"]',
    "a 400-digit x": b'{"t":"drive","v":1,"id":5,"x":' + b"1" * 400 + b',"y":0,"time":0}',
    "64 KB of 30-digit numbers": b"[" + b",".join([b"1" * 30] * 2100) + b"]",
}


def refused(data: bytes) -> None:
    try:
        decode(data)
    except RemoteProtocolError:
        return
    raise AssertionError("decoded a frame that must be refused")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    print("load average {:.2f} {:.2f} {:.2f} on {} CPUs".format(*os.getloadavg(), os.cpu_count()))
    frame = encode(DriveToPosition(7, 3.0, 4.0, 2.5))
    n = 100_000
    ours = min(timeit.repeat(lambda: decode(frame), number=n, repeat=args.repeat)) / n
    bare = min(timeit.repeat(lambda: json.loads(frame), number=n, repeat=args.repeat)) / n
    print("typical drive frame ({} bytes): decode {:.1f} us, bare json.loads {:.1f} us "
          "({:.1f}x)".format(len(frame), ours * 1e6, bare * 1e6, ours / bare))
    for name, data in FRAMES.items():
        best = min(timeit.repeat(lambda: refused(data), number=20, repeat=args.repeat)) / 20
        print("{:<28} {:>6} bytes: refused in {:.2f} ms".format(name, len(data), best * 1e3))


if __name__ == "__main__":
    main()
