//! The RIHS01 type hashes (what rmw_zenoh puts in key expressions and rosbag2 in metadata.yaml)
//! of the standard types this node publishes and the sensor adapter takes, computed by
//! `nrslam_runtime::type_hash` from nrslam's definitions, against values computed by code we did
//! not write from ROS 2 Jazzy's own definitions: rosbags 0.11.9's Jazzy type store
//! (`get_typestore(Stores.ROS2_JAZZY).hash_rihs01(name)`), and for RadarScan (not in that store)
//! the `type_description_hash` rosbags wrote into the fixture bag's metadata.yaml
//! (tests/fixtures/ros2/bags/v9_plain), whose PointCloud2 and PoseStamped hashes are checked too.

use nrslam_runtime::type_hash::rihs01;

#[test]
fn standard_type_hashes_are_those_of_ros2_jazzy() {
    let cases = [
        (
            "sensor_msgs/msg/PointCloud2",
            "RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5",
        ),
        (
            "sensor_msgs/msg/PointField",
            "RIHS01_5c6a4750728c2bcfbbf7037225b20b02d4429634732146b742dee1726637ef01",
        ),
        (
            "radar_msgs/msg/RadarScan",
            "RIHS01_9d270e9c9d9e2509e93e7c688fd8a813d75e43a6a37ef982e63e24e80e535cdc",
        ),
        (
            "geometry_msgs/msg/PoseStamped",
            "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8",
        ),
        (
            "tf2_msgs/msg/TFMessage",
            "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
        ),
        (
            "geometry_msgs/msg/TransformStamped",
            "RIHS01_0a241f87d04668d94099cbb5ba11691d5ad32c2f29682e4eb5653424bd275206",
        ),
        (
            "geometry_msgs/msg/Transform",
            "RIHS01_beb83fbe698636351461f6f35d1abb20010c43d55374d81bd041f1ba2581fddc",
        ),
        (
            "nav_msgs/msg/Path",
            "RIHS01_1957a5bb3cee5da65c4e52e52b65a93df227efce4c20f8458b36e73066ca334b",
        ),
        (
            "visualization_msgs/msg/MarkerArray",
            "RIHS01_86cb8800b6fb05b5eff1abd7a56f62a5641d3ae9a1c29e78e67e704f1d067dcf",
        ),
        (
            "visualization_msgs/msg/Marker",
            "RIHS01_45b13ccf791f225962bf74e746f9644518855d783a6f42ba0cc14fde2b4f3ce0",
        ),
        (
            "visualization_msgs/msg/MeshFile",
            "RIHS01_7710ece15a148fb7c9b546364cfb215bb06098087bd6394fe5b73a493508f8c4",
        ),
        (
            "visualization_msgs/msg/UVCoordinate",
            "RIHS01_f27f7ed21fe360c6066944f856b801a0c0d1e94e815b6886444b42d90b196a26",
        ),
        (
            "sensor_msgs/msg/CompressedImage",
            "RIHS01_15640771531571185e2efc8a100baf923961a4d15d5569652e6cb6691e8e371a",
        ),
        (
            "std_msgs/msg/ColorRGBA",
            "RIHS01_77a7a5b9ae477306097665106e0413ba74440245b1f3d0c6d6405fe5c7813fe8",
        ),
        (
            "builtin_interfaces/msg/Duration",
            "RIHS01_e8d009f659816f758b75334ee1a9ca5b5c0b859843261f14c7f937349599d93b",
        ),
    ];
    for (name, expected) in cases {
        assert_eq!(rihs01(name).unwrap(), expected, "{name}");
    }
}
