"""Reads a hardbody MCAP log with the standard Python readers and decodes
every channel: /stats and /state as JSON, /scene with Foxglove's published
protobuf schema (foxglove-schemas-protobuf). Exits non-zero, naming the
problem, if anything does not decode or does not agree.

usage: python3 tests/python/read_log.py LOG.mcap
"""
import json
import sys

from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.reader import make_reader


def main(path):
    counts = {}
    states = []
    scenes = []
    stats = []
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        channels = {c.topic: c for c in summary.channels.values()}
        for topic, encoding in [("/stats", "json"), ("/state", "json"), ("/scene", "protobuf")]:
            assert topic in channels, f"no {topic} channel"
            assert channels[topic].message_encoding == encoding, (topic, channels[topic].message_encoding)
        scene_schema = summary.schemas[channels["/scene"].schema_id]
        assert scene_schema.name == "foxglove.SceneUpdate", scene_schema.name
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        assert "hardbody" in metadata, "no hardbody metadata"
        assert "Scene(" in metadata["hardbody"]["scene"], "scene text missing"
        assert metadata["hardbody"]["version"], "version missing"
        last_time = -1
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            assert message.log_time >= last_time or channel.topic != "/stats", "log time went back"
            if channel.topic == "/stats":
                last_time = message.log_time
                stats.append(json.loads(message.data))
            elif channel.topic == "/state":
                states.append(json.loads(message.data))
            elif channel.topic == "/scene":
                update = SceneUpdate()
                update.ParseFromString(message.data)
                scenes.append(update)
    assert counts.get("/scene") == counts.get("/state"), counts
    for update, state in zip(scenes, states):
        ids = [e.id for e in update.entities]
        assert ids == ["particles", "box"], ids
        particles = update.entities[0]
        drawn = len(particles.spheres) + len(particles.cubes) + len(particles.triangles)
        assert drawn == len(state["positions"]), (drawn, len(state["positions"]))
        assert particles.frame_id == "hardbody"
        assert len(update.entities[1].lines[0].points) == 24
        # Quaternion order: /state [w, x, y, z], Foxglove {x, y, z, w}.
        prims = list(particles.spheres) + list(particles.cubes) + list(particles.triangles)
        q = prims[0].pose.orientation
        w, x, y, z = state["orientations"][0]
        if len(set(state["species_of"])) == 1:  # primitives in particle order
            assert (q.w, q.x, q.y, q.z) == (w, x, y, z), ((q.w, q.x, q.y, q.z), (w, x, y, z))
    for s in stats:
        for key in ["stage", "stage_index", "packing_fraction", "pressure", "box", "nematic_order"]:
            assert key in s, f"/stats lacks {key}"
    print(json.dumps({"messages": counts, "frames": len(states), "stats": len(stats),
                      "last_stats": stats[-1] if stats else None}))


if __name__ == "__main__":
    main(sys.argv[1])
