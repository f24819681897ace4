"""An independent Foxglove WebSocket client (PyPI `websockets`) for `terzaghi node --foxglove`.

It offers both names of the protocol, as the Foxglove app and Lichtblick (since its PR #819) do:
`foxglove.sdk.v1`, which the `foxglove` crate's server speaks, and `foxglove.websocket.v1`, its
older name (the same messages).

`live` mode: connects as the Foxglove app does, reads the server's channel advertisements,
subscribes to TOPICS, and decodes each binary message with the schema the server advertised
(mcap-ros2-support's decoder built from the `ros2msg` text, nothing of terzaghi's). Prints a
JSON object: per topic, the schema name, the count received and the decoded messages' fields
asked for.

`stuck` mode: connects, subscribes to every channel, and then never reads again (its receive
buffer small), as a frozen client would, for SECONDS; prints how long it stayed connected.
"""
import argparse
import asyncio
import json
import socket
import struct
import sys
import time

import websockets
from mcap_ros2._dynamic import generate_dynamic

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]


async def connect(url, timeout_s):
    end = time.monotonic() + timeout_s
    while True:
        try:
            return await websockets.connect(url, subprotocols=SUBPROTOCOLS, max_size=None)
        except OSError:
            if time.monotonic() > end:
                raise
            await asyncio.sleep(0.1)


async def advertised(ws, topics, timeout_s):
    """Channels advertised by the server, by topic, until every one of `topics` is there."""
    channels = {}
    end = time.monotonic() + timeout_s
    while not all(t in channels for t in topics):
        left = end - time.monotonic()
        if left <= 0:
            break
        msg = await asyncio.wait_for(ws.recv(), left)
        if isinstance(msg, str):
            m = json.loads(msg)
            if m.get("op") == "advertise":
                for c in m["channels"]:
                    channels[c["topic"]] = c
    return channels


async def live(args):
    topics = args.topics
    ws = await connect(args.url, args.timeout)
    out = {"subprotocol": ws.subprotocol, "topics": {}}
    channels = await advertised(ws, topics, args.timeout)
    subs, decoders = {}, {}
    for k, t in enumerate(topics):
        c = channels.get(t)
        if c is None:
            out["topics"][t] = {"advertised": False}
            continue
        decoders[k + 1] = (t, generate_dynamic(c["schemaName"], c["schema"])[c["schemaName"]])
        subs[k + 1] = c["id"]
        out["topics"][t] = {"advertised": True, "schemaName": c["schemaName"], "encoding": c["encoding"],
                            "schemaEncoding": c.get("schemaEncoding"), "received": 0, "messages": []}
    await ws.send(json.dumps({"op": "subscribe",
                              "subscriptions": [{"id": s, "channelId": c} for s, c in subs.items()]}))
    end = time.monotonic() + args.seconds
    while time.monotonic() < end:
        try:
            msg = await asyncio.wait_for(ws.recv(), max(0.01, end - time.monotonic()))
        except asyncio.TimeoutError:
            break
        if isinstance(msg, bytes) and msg[0] == 0x01:
            sub_id, log_time = struct.unpack_from("<IQ", msg, 1)
            topic, decode = decoders[sub_id]
            m = decode(msg[13:])
            entry = out["topics"][topic]
            entry["received"] += 1
            if len(entry["messages"]) < args.keep:
                entry["messages"].append(fields(m))
    await ws.close()
    emit(args, out)


def fields(m):
    """The decoded message as JSON-able data."""
    if isinstance(m, (int, float, str, bool)) or m is None:
        return m
    if isinstance(m, (list, tuple)):
        return [fields(x) for x in m]
    if isinstance(m, (bytes, bytearray)):
        return list(m)
    return {k: fields(getattr(m, k)) for k in m.__slots__} if hasattr(m, "__slots__") else str(m)


async def stuck(args):
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    # A tiny receive window: the server's sends block almost at once.
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    host, port = args.url.split("//", 1)[1].rsplit(":", 1)
    end = time.monotonic() + args.timeout
    while True:
        try:
            sock.connect((host, int(port)))
            break
        except OSError:
            if time.monotonic() > end:
                raise
            await asyncio.sleep(0.1)
            sock.close()
            sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    ws = await websockets.connect(args.url, subprotocols=SUBPROTOCOLS, sock=sock, max_size=None)
    channels = await advertised(ws, args.topics, args.timeout)
    await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
        {"id": k + 1, "channelId": c["id"]} for k, c in enumerate(channels.values())]}))
    # Never read again: the library's reader is paused once its buffer is full.
    ws.transport.pause_reading()
    start = time.monotonic()
    closed_by_server = None
    while time.monotonic() - start < args.seconds:
        if ws.transport.is_closing():
            closed_by_server = time.monotonic() - start
            break
        await asyncio.sleep(0.1)
    emit(args, {"subscribed": len(channels), "closed_by_server_after_s": closed_by_server,
                "seconds": args.seconds})


def emit(args, out):
    text = json.dumps(out)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    else:
        print(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mode", choices=["live", "stuck"])
    ap.add_argument("--url", required=True, help="ws://127.0.0.1:PORT")
    ap.add_argument("--topics", nargs="+", required=True)
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--timeout", type=float, default=20.0, help="to connect and see the topics advertised")
    ap.add_argument("--keep", type=int, default=5, help="decoded messages kept per topic")
    ap.add_argument("--out", default="", help="write the JSON here instead of standard output")
    args = ap.parse_args()
    asyncio.run(live(args) if args.mode == "live" else stuck(args))


if __name__ == "__main__":
    sys.exit(main())
