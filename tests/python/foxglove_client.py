"""Connects to `vservoctl view` as Foxglove does (the public WebSocket protocol, subprotocol
`foxglove.sdk.v1`, with the `websockets` package from PyPI), and checks what a user would see: the channels
advertised with Foxglove's schema names; images; annotations whose marks are exactly the features the servo
used in that frame; joint states and the daemon's status. Prints one JSON line of figures; exits 1 with the
reason on failure.
Usage: foxglove_client.py URL INSTANCE SECONDS (URL with the view's token: `vservoctl view --url` prints it)"""

import asyncio
import base64
import json
import struct
import sys

import websockets
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory


def fail(why: str) -> None:
    print(f"foxglove_client: {why}", file=sys.stderr)
    sys.exit(1)


def message_class(schema_name: str, schema_b64: str):
    """The protobuf class of a channel, from the FileDescriptorSet the server advertised."""
    files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(schema_b64))
    pool = descriptor_pool.DescriptorPool()
    for f in files.file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))


async def main(url: str, instance: str, seconds: float) -> dict:
    wanted = {"/camera/image": "foxglove.RawImage", "/camera/annotations": "foxglove.ImageAnnotations",
              "/tf": "foxglove.FrameTransforms", f"vservo/{instance}/features": "vservo::Features",
              f"vservo/{instance}/joint_state": "vservo::JointState", f"vservo/{instance}/status": "vservo::DaemonStatus"}
    channels = {}
    loop = asyncio.get_running_loop()
    connect_by = loop.time() + 10  # the server may still be starting
    while True:
        try:
            ws = await websockets.connect(url, subprotocols=["foxglove.sdk.v1"], max_size=None)
            break
        except OSError:
            if loop.time() > connect_by:
                raise
            await asyncio.sleep(0.2)
    async with ws:
        deadline = loop.time() + 10
        while set(wanted) - set(channels):
            if loop.time() > deadline:
                fail(f"advertised only {sorted(channels)}")
            message = json.loads(await asyncio.wait_for(ws.recv(), timeout=10))
            if message.get("op") == "advertise":
                for c in message["channels"]:
                    channels[c["topic"]] = c
        for topic, name in wanted.items():
            if channels[topic]["schemaName"] != name:
                fail(f"{topic}: schema {channels[topic]['schemaName']}, not {name}")
        by_sub = {}
        subscriptions = []
        for n, topic in enumerate(wanted, start=1):
            by_sub[n] = topic
            subscriptions.append({"id": n, "channelId": channels[topic]["id"]})
        await ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))
        classes = {t: message_class(channels[t]["schemaName"], channels[t]["schema"])
                   for t in ["/camera/image", "/camera/annotations"]}
        features, annotations, image_stamps = {}, {}, set()
        joint_ticks, statuses = set(), 0
        end = loop.time() + seconds
        while loop.time() < end:
            try:
                frame = await asyncio.wait_for(ws.recv(), timeout=max(0.01, end - loop.time()))
            except asyncio.TimeoutError:
                break
            if isinstance(frame, str) or frame[0] != 1:
                continue
            sub, _log_time = struct.unpack_from("<IQ", frame, 1)
            payload = frame[13:]
            topic = by_sub.get(sub)
            if topic == f"vservo/{instance}/features":
                data = json.loads(payload)
                features[data["capture_stamp_ns"]] = (data["valid_mask"], data["features_px"])
            elif topic == f"vservo/{instance}/joint_state":
                joint_ticks.add(json.loads(payload)["tick"])
            elif topic == f"vservo/{instance}/status":
                statuses += 1 if "state" in json.loads(payload) else 0
            elif topic == "/camera/image":
                image = classes[topic].FromString(payload)
                image_stamps.add(image.timestamp.seconds * 10**9 + image.timestamp.nanos)
            elif topic == "/camera/annotations":
                drawn = classes[topic].FromString(payload)
                stamp = drawn.timestamp.seconds * 10**9 + drawn.timestamp.nanos
                annotations[stamp] = [(c.position.x, c.position.y) for c in drawn.circles if c.diameter == 14.0]
    checked = 0
    for stamp, (mask, xi) in features.items():
        if stamp in annotations:
            used = [(xi[2 * m], xi[2 * m + 1]) for m in range(4) if mask & (1 << m)]
            if annotations[stamp] != used:
                fail(f"frame at {stamp} ns: marks drawn at {annotations[stamp]}, the servo used {used}")
            checked += 1
    return {"channels": len(channels), "images": len(image_stamps), "features": len(features),
            "annotated_frames_checked": checked, "images_with_annotations": len(image_stamps & set(annotations)),
            "joint_states": len(joint_ticks), "statuses": statuses}


if __name__ == "__main__":
    figures = asyncio.run(main(sys.argv[1], sys.argv[2], float(sys.argv[3])))
    print(json.dumps(figures))
