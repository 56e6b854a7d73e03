#!/usr/bin/env python3
"""Write a recorded nrslam bag again with a bag writer the project did not write, so that it carries
no nrslam launch record: what a bag from another tool looks like to `launch/replay.toml`.

  pip install rosbags mcap mcap-ros2-support
  python3 scripts/rewrite_bag_external.py rosbags out/bag-ideal out/bag-rosbags
  python3 scripts/rewrite_bag_external.py mcap    out/bag-ideal out/bag-mcap
  nrslam launch launch/replay.toml bag:=out/bag-rosbags      # one warning line, exit 0

rosbags: the rosbags rosbag2 Writer (version 9, MCAP storage) writes every connection and message
  of the source (read with the rosbags Reader): a rosbag2 folder with its own metadata.yaml,
  custom_data null.
mcap: the Python `mcap` package's Writer writes one MCAP file with the source's schemas, channels
  and messages, and no metadata record. The mcap tools write no metadata.yaml, so DST is a folder
  holding that lone file, `DST/DST_0.mcap`.
"""
import sys
from pathlib import Path


def with_rosbags(src: Path, dst: Path) -> int:
    from rosbags.rosbag2 import Reader, StoragePlugin, Writer

    count = 0
    with Reader(src) as reader, Writer(dst, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {}
        for connection in reader.connections:
            connections[connection.id] = writer.add_connection(
                connection.topic,
                connection.msgtype,
                msgdef=connection.msgdef.data,
                rihs01=connection.digest,
                serialization_format="cdr",
                offered_qos_profiles=connection.ext.offered_qos_profiles,
            )
        for connection, timestamp, raw in reader.messages():
            writer.write(connections[connection.id], timestamp, raw)
            count += 1
    return count


def with_mcap(src: Path, dst: Path) -> int:
    from mcap.reader import make_reader
    from mcap.writer import Writer

    sources = sorted(src.glob("*.mcap"))
    dst.mkdir(parents=True)
    count = 0
    with open(dst / f"{dst.name}_0.mcap", "wb") as out:
        writer = Writer(out)
        writer.start(profile="ros2", library="python mcap")
        schemas, channels = {}, {}
        for path in sources:
            with open(path, "rb") as f:
                for schema, channel, message in make_reader(f).iter_messages():
                    if schema.name not in schemas:
                        schemas[schema.name] = writer.register_schema(
                            name=schema.name, encoding=schema.encoding, data=schema.data
                        )
                    if channel.topic not in channels:
                        channels[channel.topic] = writer.register_channel(
                            topic=channel.topic,
                            message_encoding=channel.message_encoding,
                            schema_id=schemas[schema.name],
                            metadata=dict(channel.metadata),
                        )
                    writer.add_message(
                        channel_id=channels[channel.topic],
                        log_time=message.log_time,
                        publish_time=message.publish_time,
                        data=message.data,
                        sequence=message.sequence,
                    )
                    count += 1
        writer.finish()
    return count


def main() -> None:
    if len(sys.argv) != 4 or sys.argv[1] not in ("rosbags", "mcap"):
        sys.exit(__doc__)
    src, dst = Path(sys.argv[2]), Path(sys.argv[3])
    if dst.exists():
        sys.exit(f"{dst}: exists; give a new folder")
    count = (with_rosbags if sys.argv[1] == "rosbags" else with_mcap)(src, dst)
    print(f"wrote {count} messages into {dst} with {sys.argv[1]}")


if __name__ == "__main__":
    main()
