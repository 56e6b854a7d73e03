//! Golden tests of rmw_zenoh's discovery formats, from rmw_zenoh's own documents and code (not
//! from nrslam's encoder).
//!
//! - Token and key-expression literals: the examples of rmw_zenoh's `docs/design.md` at commit
//!   `99a6a2bd10b949052f4f12c5854825dc005e95a5` ("Topic and Service name mapping to Zenoh key
//!   expressions" and "Graph Cache"), copied verbatim.
//! - GID literals: printed by rmw_zenoh's own hash, `rmw_zenoh_cpp/src/detail/simplified_xxhash3.cpp`
//!   at commit `97aed4819677b9825b20bb44a01707f42843e06a`, arranged as `Entity::Entity` does
//!   (`memcpy` of `low64` then `high64`). To regenerate, with that file and its header in a folder:
//!
//!   ```text
//!   cat > gid.cpp <<'EOF'
//!   #include <cstdio>
//!   #include <cstring>
//!   #include <cstdint>
//!   #include "simplified_xxhash3.hpp"
//!   int main(int argc, char ** argv) {
//!     for (int i = 1; i < argc; ++i) {
//!       simplified_XXH128_hash_t h = simplified_XXH3_128bits(argv[i], strlen(argv[i]));
//!       uint8_t gid[16];
//!       memcpy(gid, &h.low64, 8);
//!       memcpy(gid + 8, &h.high64, 8);
//!       for (int b = 0; b < 16; ++b) printf("%02x", gid[b]);
//!       printf("  %s\n", argv[i]);
//!     }
//!   }
//!   EOF
//!   g++ -O2 -o gid gid.cpp simplified_xxhash3.cpp && ./gid '<token>' ...
//!   ```

use nrslam_runtime::rmw_zenoh::{
    dds_type_name, gid, key_expr_with_hash, liveliness_token, mangle_name, qos_to_keyexpr,
    DurabilityPolicy, EntityKind, EntityQos, HistoryPolicy, NodeInfo, ReliabilityPolicy, TopicInfo,
    DEFAULT_QOS,
};

/// `std_msgs/msg/String`'s hash, as the design document prints it.
const STRING_HASH: &str = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18";

const LISTENER_NN: &str = "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener";
const LISTENER_MS: &str = "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/10/MS/%/%/listener/%chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,10:,:,:,,";
const TALKER_MP: &str = "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,7:,:,:,,";

fn node(zid: &str, name: &str) -> NodeInfo {
    NodeInfo {
        domain_id: 2,
        zid: zid.into(),
        node_id: 0,
        enclave: "/".into(),
        namespace: "/".into(),
        name: name.into(),
    }
}

fn chatter(depth: usize) -> TopicInfo {
    TopicInfo {
        name: "/chatter".into(),
        dds_type: dds_type_name("std_msgs/msg/String"),
        type_hash: STRING_HASH.into(),
        qos: EntityQos {
            depth,
            ..DEFAULT_QOS
        },
    }
}

#[test]
fn node_token_is_the_design_documents_listener() {
    let listener = node("aac3178e146ba6f1fc6e6a4085e77f21", "listener");
    assert_eq!(
        liveliness_token(&listener, 0, EntityKind::Node, None),
        LISTENER_NN
    );
}

#[test]
fn subscription_and_publisher_tokens_are_the_design_documents() {
    let listener = node("aac3178e146ba6f1fc6e6a4085e77f21", "listener");
    assert_eq!(
        liveliness_token(&listener, 10, EntityKind::Subscription, Some(&chatter(10))),
        LISTENER_MS
    );
    let talker = node("8b20917502ee955ac4476e0266340d5c", "talker");
    assert_eq!(
        liveliness_token(&talker, 10, EntityKind::Publisher, Some(&chatter(7))),
        TALKER_MP
    );
}

#[test]
fn string_hash_in_the_tokens_is_the_one_computed_from_its_definition() {
    let computed = nrslam_runtime::type_hash::rihs01_with("std_msgs/msg/String", &|name| {
        (name == "std_msgs/msg/String").then(|| "string data\n".to_owned())
    })
    .unwrap();
    assert_eq!(computed, STRING_HASH);
}

#[test]
fn data_key_expressions_are_the_design_documents() {
    assert_eq!(
        key_expr_with_hash(0, "/chatter", "std_msgs/msg/String", STRING_HASH),
        "0/chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
    );
    assert_eq!(
        key_expr_with_hash(0, "/robot1/chatter", "std_msgs/msg/String", STRING_HASH),
        "0/robot1/chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
    );
    assert_eq!(
        key_expr_with_hash(2, "/add_two_ints", "example_interfaces/srv/AddTwoInts", "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"),
        "2/add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"
    );
}

/// `qos_to_keyexpr` (liveliness_utils.cpp) leaves every default of qos.cpp empty and writes
/// the rmw enum value of the others (rmw/types.h: TRANSIENT_LOCAL 1, BEST_EFFORT 2, KEEP_ALL 2).
#[test]
fn qos_strings_leave_defaults_empty_and_number_the_rest() {
    assert_eq!(qos_to_keyexpr(&DEFAULT_QOS), "::,:,:,:,,");
    let latched = EntityQos {
        durability: DurabilityPolicy::TransientLocal,
        depth: 1,
        ..DEFAULT_QOS
    };
    assert_eq!(qos_to_keyexpr(&latched), ":1:,1:,:,:,,");
    let sensor = EntityQos {
        reliability: ReliabilityPolicy::BestEffort,
        history: HistoryPolicy::KeepAll,
        depth: 5,
        ..DEFAULT_QOS
    };
    assert_eq!(qos_to_keyexpr(&sensor), "2::2,5:,:,:,,");
    // Depth 0 is "choose", and rmw_zenoh chooses its default, 42: left empty.
    let zero = EntityQos {
        depth: 0,
        ..DEFAULT_QOS
    };
    assert_eq!(qos_to_keyexpr(&zero), "::,:,:,:,,");
}

#[test]
fn names_are_mangled_slash_for_percent() {
    assert_eq!(mangle_name("/"), "%");
    assert_eq!(mangle_name("/robot1/map/segments"), "%robot1%map%segments");
    assert_eq!(mangle_name("talker"), "talker");
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

#[test]
fn gids_are_the_ones_rmw_zenohs_own_hash_gives() {
    // (GID printed by rmw_zenoh's simplified_xxhash3.cpp, token): see the module documentation.
    let golden = [
        ("7f498d4624c30160d8984701d306aa99", String::new()),
        ("49877999dacb858702d11ac823785912", LISTENER_NN.to_owned()),
        ("76148a538308fe55a6c5375462ca1de6", LISTENER_MS.to_owned()),
        ("ac170f31eadcd9ff0cd86d7a17907d1c", TALKER_MP.to_owned()),
        ("3df861677fc7f7a0e61a00326243b94b", "@ros2_lv/0/1f/0/0/NN/%/%/a".to_owned()),
        (
            "ece94734de12f0de048916a599a4a8e2",
            // 347 bytes: XXH3's long-input path.
            format!(
                "@ros2_lv/7/c0ffee0123456789abcdef0123456789/4/11/MS/%/%robot_with_a_rather_long_namespace%front_left_sensor_suite/keyframe_pose_graph_optimiser/%robot_with_a_rather_long_namespace%front_left_sensor_suite%slam%keyframe_poses/nrslam_msgs::msg::dds_::KeyframePoses_/RIHS01_{}/:1:,1:,:,:,,",
                "0".repeat(64)
            ),
        ),
    ];
    for (expected, token) in golden {
        assert_eq!(hex(&gid(&token)), expected, "{token}");
    }
}
