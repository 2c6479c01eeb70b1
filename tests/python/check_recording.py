"""Reads a `vservoctl record` file with the `mcap` package from PyPI (and `mcap-protobuf-support` to decode
Foxglove's protobuf messages), as a user's own tooling would, and checks what Foxglove needs to show it as
pictures: compressed chunks; camera images, image annotations and transforms under Foxglove's schema names;
each annotation's marks exactly at the features the servo used in that frame; the collision guard's obstacles
as scene entities (each one's frame, cubes, texts) where the cell has any. Prints one JSON line of
figures; exits 1 with the reason on the first failure. Usage: check_recording.py FILE INSTANCE"""

import json
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def fail(why: str) -> None:
    print(f"check_recording: {why}", file=sys.stderr)
    sys.exit(1)


def main() -> int:
    path, instance = sys.argv[1], sys.argv[2]
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        compressions = {c.compression for c in summary.chunk_indexes}
        if not compressions or compressions - {"zstd", "lz4"}:
            fail(f"chunks compressed with {compressions or 'nothing'}")
        schemas = {summary.channels[c].topic: summary.schemas[summary.channels[c].schema_id].name
                   for c in summary.channels}
        wanted = {"/camera/image": "foxglove.RawImage", "/camera/annotations": "foxglove.ImageAnnotations",
                  "/tf": "foxglove.FrameTransforms"}
        for topic, name in wanted.items():
            if schemas.get(topic) != name:
                fail(f"{topic}: schema {schemas.get(topic)}, not {name}")
        features = {}  # capture stamp → (valid mask, ξ)
        annotations = {}  # capture stamp → measured circle centres
        images, image_stamps, frames_seen = 0, set(), set()
        obstacles = {}  # entity id → what it draws (the newest update)
        # vservo's own services are JSON: read as bytes
        for schema, channel, message in reader.iter_messages(topics=[f"vservo/{instance}/features"]):
            data = json.loads(message.data)
            features[data["capture_stamp_ns"]] = (data["valid_mask"], data["features_px"])
        for schema, channel, message, decoded in reader.iter_decoded_messages(
                topics=["/camera/image", "/camera/annotations", "/tf", "/scene/obstacles"]):
            if channel.topic == "/camera/image":
                images += 1
                if decoded.encoding != "mono8" or len(decoded.data) != decoded.step * decoded.height:
                    fail(f"an image of {decoded.width}×{decoded.height} {decoded.encoding}, {len(decoded.data)} bytes")
                image_stamps.add(decoded.timestamp.seconds * 10**9 + decoded.timestamp.nanos)
            elif channel.topic == "/camera/annotations":
                stamp = decoded.timestamp.seconds * 10**9 + decoded.timestamp.nanos
                annotations[stamp] = [(c.position.x, c.position.y) for c in decoded.circles if c.diameter == 14.0]
            elif channel.topic == "/scene/obstacles":
                for entity in decoded.entities:
                    obstacles[entity.id] = {
                        "frame_id": entity.frame_id,
                        "cube_sizes": [[c.size.x, c.size.y, c.size.z] for c in entity.cubes],
                        "cube_centres": [[c.pose.position.x, c.pose.position.y, c.pose.position.z]
                                         for c in entity.cubes],
                        "texts": [t.text for t in entity.texts]}
            else:
                frames_seen.update(t.child_frame_id for t in decoded.transforms)
    if images == 0:
        fail("no images")
    checked = 0
    for stamp, (mask, xi) in features.items():
        if stamp not in annotations:
            fail(f"the frame captured at {stamp} ns has no annotations")
        used = [(xi[2 * m], xi[2 * m + 1]) for m in range(4) if mask & (1 << m)]
        if annotations[stamp] != used:
            fail(f"frame at {stamp} ns: marks drawn at {annotations[stamp]}, the servo used {used}")
        checked += 1
    paired = len(image_stamps & set(annotations))
    for frame in ["link1", "link6", "camera", "board"]:
        if frame not in frames_seen:
            fail(f"no transform to {frame} (saw {sorted(frames_seen)})")
    print(json.dumps({"images": images, "annotated_frames": checked, "images_with_annotations": paired,
                      "compression": sorted(compressions), "frames": sorted(frames_seen),
                      "obstacles": obstacles}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
