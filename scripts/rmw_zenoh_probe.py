#!/usr/bin/env python3
"""An independent rmw_zenoh client: does a zenoh graph look like ROS 2 on rmw_zenoh?

Written from rmw_zenoh's docs/design.md (commit 99a6a2bd10b949052f4f12c5854825dc005e95a5), not
from nrslam's code, with the eclipse-zenoh Python package (1.x). It does what an rmw_zenoh
context does at start-up and what `ros2 node list`, `ros2 topic list -t` and `ros2 topic echo`
then need:

1. opens a zenoh session (client of --connect, or peer listening on --listen), multicast off;
2. queries liveliness `@ros2_lv/<domain>/**` ("Graph Cache") until a publisher (MP) token of
   --topic appears, and prints the node (NN) and publisher (MP) tokens;
3. checks that token: <type_name> is --type in DDS form (`nav_msgs::msg::dds_::OccupancyGrid_`),
   <type_hash> is --hash (for /map: ROS 2 Jazzy's published RIHS01 of nav_msgs/msg/OccupancyGrid;
   rosbags' Jazzy type store recomputes it when installed), the QoS field has rmw_zenoh's 6 parts;
4. subscribes to the data key `<domain>/<topic>/<type>/<hash>` ("Topic and Service name mapping")
   and checks each sample's attachment ("Publishers"): 33 bytes = sequence number (int64 LE),
   source timestamp (int64 LE, ns since the UNIX epoch), GID length byte 16, 16 GID bytes;
   sequence numbers increase, the GID is the same on every sample and, when the `xxhash` package
   is installed, equals XXH3-128 of the MP token (what rmw_zenoh's liveliness_utils.cpp computes;
   the design document does not say how GIDs are made, so this check is optional);
5. decodes the payload as CDR with rosbags (when installed) and prints its header and size;
6. with --latched TOPIC TYPE: joins late on a transient-local topic with a zenoh-ext
   AdvancedSubscriber (history, late-publisher detection), as an rmw_zenoh subscription does
   ("Quality of Service", TRANSIENT_LOCAL), and expects the cached message.

Exit status 0 when every check passes, 1 otherwise (each failure printed).

Example (nrslam's paper graph, ROS domain 0):
    nrslam launch launch/paper-ideal.toml --rate 1 --ros-domain-id 0 --listen tcp/127.0.0.1:7447 &
    python3 scripts/rmw_zenoh_probe.py --connect tcp/127.0.0.1:7447 \
        --latched /ground_truth/targets nrslam_msgs/msg/TargetSet
"""

import argparse
import struct
import sys
import time

import zenoh
import zenoh.ext

# nav_msgs/msg/OccupancyGrid, ROS 2 Jazzy (`ros2 topic info -v /map`).
OCCUPANCY_GRID_HASH = "RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7"

FAILURES = []


def check(condition, what):
    print(("  ok    " if condition else "  FAIL  ") + what)
    if not condition:
        FAILURES.append(what)
    return condition


def dds_type(ros_type):
    """`pkg/msg/Type` -> `pkg::msg::dds_::Type_` (design.md: "as declared in DDS")."""
    package, kind, name = ros_type.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def demangle(part):
    """Mangled names have each '/' replaced by '%' (design.md, "Graph Cache")."""
    return part.replace("%", "/")


def parse_token(key):
    """The fields of a liveliness token, or None if it is not one (design.md layout)."""
    parts = key.split("/")
    if len(parts) < 9 or parts[0] != "@ros2_lv":
        return None
    token = {
        "domain": parts[1], "session": parts[2], "node_id": parts[3], "entity_id": parts[4],
        "kind": parts[5], "enclave": demangle(parts[6]), "namespace": demangle(parts[7]),
        "node": parts[8], "key": key,
    }
    if token["kind"] != "NN":
        if len(parts) != 13:
            return None
        token.update(topic=demangle(parts[9]), type=parts[10], hash=parts[11], qos=parts[12])
    return token


def open_session(args):
    config = zenoh.Config()
    config.insert_json5("scouting/multicast/enabled", "false")
    if args.connect:
        config.insert_json5("mode", '"client"')
        config.insert_json5("connect/endpoints", f'["{args.connect}"]')
    else:
        config.insert_json5("mode", '"peer"')
        config.insert_json5("listen/endpoints", f'["{args.listen}"]')
    return zenoh.open(config)


def discover(session, args):
    """Liveliness tokens of the domain, polled until an MP token of --topic shows up."""
    deadline = time.monotonic() + args.timeout_s
    while True:
        tokens = []
        for reply in session.liveliness().get(f"@ros2_lv/{args.domain}/**", timeout=5.0):
            if reply.ok is not None:
                token = parse_token(str(reply.ok.key_expr))
                if token is not None:
                    tokens.append(token)
        if any(t["kind"] == "MP" and t["topic"] == args.topic for t in tokens):
            return tokens
        if time.monotonic() > deadline:
            return tokens
        time.sleep(0.2)


def parse_attachment(data):
    """(sequence, timestamp_ns, gid) of an rmw_zenoh attachment, or None."""
    if len(data) != 33 or data[16] != 16:
        return None
    sequence, stamp_ns = struct.unpack_from("<qq", data, 0)
    return sequence, stamp_ns, bytes(data[17:33])


def expected_gid(token_key):
    try:
        import xxhash
    except ImportError:
        return None
    return xxhash.xxh3_128_intdigest(token_key.encode()).to_bytes(16, "little")


def decode(payload, ros_type):
    try:
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        return None
    return get_typestore(Stores.ROS2_JAZZY).deserialize_cdr(payload, ros_type)


def receive(session, key, count, timeout_s):
    received = []
    subscriber = session.declare_subscriber(key, lambda sample: received.append(sample))
    deadline = time.monotonic() + timeout_s
    while len(received) < count and time.monotonic() < deadline:
        time.sleep(0.05)
    subscriber.undeclare()
    return received[:count]


def check_samples(samples, mp_token, args):
    gid_expected = expected_gid(mp_token["key"])
    last_sequence, gids = 0, set()
    for index, sample in enumerate(samples):
        attachment = sample.attachment
        data = attachment.to_bytes() if attachment is not None else b""
        check(len(data) == 33, f"sample {index}: attachment is 33 bytes (got {len(data)})")
        fields = parse_attachment(data)
        if not check(fields is not None, f"sample {index}: attachment decodes"):
            continue
        sequence, stamp_ns, gid = fields
        age_s = time.time() - stamp_ns / 1e9
        print(f"        sequence {sequence}, source timestamp {stamp_ns} ns ({age_s:.2f} s ago), "
              f"GID {gid.hex()}")
        check(sequence > last_sequence, f"sample {index}: sequence number increases")
        check(abs(age_s) < 3600, f"sample {index}: source timestamp is wall-clock ns")
        last_sequence = sequence
        gids.add(gid)
        payload = sample.payload.to_bytes()
        check(payload[:2] in (b"\x00\x01", b"\x00\x00"), f"sample {index}: CDR encapsulation header")
        message = decode(payload, args.type)
        if message is not None and index == 0:
            header = getattr(message, "header", None)
            info = getattr(message, "info", None)
            if header is not None:
                print(f"        decoded by rosbags: frame_id {header.frame_id!r}, "
                      f"stamp {header.stamp.sec}.{header.stamp.nanosec:09d}")
            if info is not None:
                print(f"        {info.width} x {info.height} cells of {info.resolution} m, "
                      f"{len(message.data)} values")
                check(len(message.data) == info.width * info.height, "data has width x height")
    check(len(gids) == 1, "one publisher GID on every sample")
    if gid_expected is None:
        print("  skip  GID = XXH3-128 of the MP token (python package xxhash not installed)")
    else:
        check(gids == {gid_expected}, "GID = XXH3-128 of the MP token (rmw_zenoh's rule)")


def check_latched(session, tokens, args):
    topic, ros_type = args.latched
    print(f"late joiner on {topic}:")
    publisher = next((t for t in tokens if t["kind"] == "MP" and t["topic"] == topic), None)
    if not check(publisher is not None, f"an MP token announces {topic}"):
        return
    check(publisher["type"] == dds_type(ros_type), f"{topic} has type {dds_type(ros_type)}")
    durability = publisher["qos"].split(":")[1]
    check(durability == "1", f"{topic} is TRANSIENT_LOCAL (durability field {durability!r})")
    key = f"{args.domain}/{topic.strip('/')}/{publisher['type']}/{publisher['hash']}"
    received = []
    subscriber = zenoh.ext.declare_advanced_subscriber(
        session, key, lambda sample: received.append(sample),
        history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1),
        subscriber_detection=True)
    deadline = time.monotonic() + args.timeout_s
    while not received and time.monotonic() < deadline:
        time.sleep(0.05)
    subscriber.undeclare()
    if check(bool(received), f"the cached {topic} reaches a subscriber that joined late"):
        attachment = received[0].attachment
        check(attachment is not None and parse_attachment(attachment.to_bytes()) is not None,
              f"{topic}: 33-byte attachment")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--connect", metavar="ENDPOINT", help="client of this endpoint")
    where.add_argument("--listen", metavar="ENDPOINT", help="peer listening here")
    parser.add_argument("--domain", type=int, default=0, help="ROS domain id (default 0)")
    parser.add_argument("--topic", default="/map", help="topic to check (default /map)")
    parser.add_argument("--type", default="nav_msgs/msg/OccupancyGrid", help="its ROS type")
    parser.add_argument("--hash", default=OCCUPANCY_GRID_HASH, help="its RIHS01 type hash")
    parser.add_argument("--samples", type=int, default=2, help="samples to receive (default 2)")
    parser.add_argument("--timeout-s", type=float, default=60.0, help="per step, seconds")
    parser.add_argument("--latched", nargs=2, metavar=("TOPIC", "TYPE"),
                        help="also check late joining on this transient-local topic")
    args = parser.parse_args()

    session = open_session(args)
    print(f"session {session.zid()}; liveliness @ros2_lv/{args.domain}/**")
    tokens = discover(session, args)
    nodes = sorted({(t["namespace"], t["node"]) for t in tokens if t["kind"] == "NN"})
    print(f"nodes (NN, {len(nodes)}):")
    for namespace, node in nodes:
        print(f"  {namespace.rstrip('/')}/{node}")
    publishers = sorted({(t["topic"], t["type"], t["node"], t["qos"])
                         for t in tokens if t["kind"] == "MP"})
    print(f"publishers (MP, {len(publishers)}):")
    for topic, dds, node, qos in publishers:
        print(f"  {topic} [{dds}] by {node}, qos {qos}")
    subscriptions = sum(1 for t in tokens if t["kind"] == "MS")
    print(f"subscriptions (MS): {subscriptions}")
    check(bool(nodes), "at least one node token")
    mp = next((t for t in tokens if t["kind"] == "MP" and t["topic"] == args.topic), None)
    if check(mp is not None, f"an MP token announces {args.topic}"):
        check(mp["type"] == dds_type(args.type), f"{args.topic} announced as {dds_type(args.type)}")
        check(mp["hash"] == args.hash, f"{args.topic} type hash is {args.hash}")
        check(len(mp["qos"].split(":")) == 6, f"{args.topic} QoS field has 6 parts ({mp['qos']})")
        check(any(t["kind"] == "NN" and t["node"] == mp["node"] and t["session"] == mp["session"]
                  for t in tokens), f"its node {mp['node']} has an NN token")
        try:
            from rosbags.typesys import Stores, get_typestore
            computed = get_typestore(Stores.ROS2_JAZZY).hash_rihs01(args.type)
            check(computed == mp["hash"], f"rosbags' Jazzy hash of {args.type} agrees")
        except ImportError:
            print("  skip  rosbags' hash (rosbags not installed)")
        key = f"{args.domain}/{args.topic.strip('/')}/{mp['type']}/{mp['hash']}"
        print(f"data key {key}:")
        samples = receive(session, key, args.samples, args.timeout_s)
        if check(len(samples) == args.samples, f"received {len(samples)} of {args.samples} samples"):
            check_samples(samples, mp, args)
    if args.latched:
        check_latched(session, tokens, args)
    session.close()
    print("PASS" if not FAILURES else f"FAIL ({len(FAILURES)} checks)")
    return 0 if not FAILURES else 1


if __name__ == "__main__":
    sys.exit(main())
