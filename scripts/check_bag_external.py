#!/usr/bin/env python3
"""Read an nrslam bag with two ROS 2 bag readers the project did not write, deserialising every
message, and print per-topic counts.

  pip install rosbags mcap mcap-ros2-support
  python3 scripts/check_bag_external.py out/bag-5g

1. rosbags (https://gitlab.com/ternaris/rosbags): opens the rosbag2 folder through its
   metadata.yaml, reads the MCAP storage, and deserialises the CDR of every message with its own
   type system: standard types from its built-in Jazzy store, project types (nrslam_msgs) parsed
   from the ros2msg schemas recorded in the bag. It also recomputes each type's RIHS01 hash and
   compares it with metadata.yaml's type_description_hash.
2. mcap-ros2-support (Foxglove's reader): decodes every message from the MCAP file alone, with
   decoders built from the recorded ros2msg schemas.

Exits non-zero if any message fails to deserialise or any count or hash disagrees.
"""
import sys
from collections import Counter
from pathlib import Path


def check_rosbags(bag: Path) -> Counter:
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore, get_types_from_msg

    typestore = get_typestore(Stores.ROS2_JAZZY)
    counts = Counter()
    with Reader(bag) as reader:
        for connection in reader.connections:
            if connection.msgtype not in typestore.types:
                typestore.register(get_types_from_msg(connection.msgdef.data, connection.msgtype))
        for connection in reader.connections:
            # connection.digest is metadata.yaml's type_description_hash.
            ours = typestore.hash_rihs01(connection.msgtype)
            if connection.digest != ours:
                sys.exit(f"rosbags: {connection.topic}: hash {connection.digest} != rosbags' {ours}")
        last_etgospa = None
        for connection, _timestamp, raw in reader.messages():
            message = typestore.deserialize_cdr(raw, connection.msgtype)
            counts[connection.topic] += 1
            if connection.topic == "/metrics":
                last_etgospa = message.etgospa
        if last_etgospa is not None:
            print(f"rosbags: last /metrics etgospa = {last_etgospa!r}")
        if sum(counts.values()) != reader.message_count:
            sys.exit(f"rosbags: read {sum(counts.values())} of {reader.message_count} messages")
    return counts


def check_mcap_ros2(bag: Path) -> Counter:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    counts = Counter()
    (mcap_file,) = sorted(bag.glob("*.mcap"))
    with open(mcap_file, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        if header.profile != "ros2":
            sys.exit(f"mcap: profile {header.profile!r}, expected 'ros2'")
        for _schema, channel, _message, decoded in reader.iter_decoded_messages():
            assert decoded is not None
            counts[channel.topic] += 1
    return counts


def main() -> None:
    if len(sys.argv) != 2:
        sys.exit("usage: check_bag_external.py BAG_DIR")
    bag = Path(sys.argv[1])
    a = check_rosbags(bag)
    b = check_mcap_ros2(bag)
    print(f"{'topic':<24} {'rosbags':>8} {'mcap_ros2':>10}")
    for topic in sorted(a):
        print(f"{topic:<24} {a[topic]:>8} {b[topic]:>10}")
    print(f"{'total':<24} {sum(a.values()):>8} {sum(b.values()):>10}")
    if a != b:
        sys.exit("the two readers disagree")
    print("every message deserialised by rosbags and by mcap_ros2; RIHS01 hashes agree with rosbags")


if __name__ == "__main__":
    main()
