//! `ros2msg` schema text for every type on the graph, with dependencies appended the way rosbag2
//! records them in MCAP: the type's own definition, then, depth-first in order of first use, each
//! dependency after a line of 80 `=` and `MSG: pkg/Type`.
//!
//! Definitions carry no comments or default values (as `rosbags` emits them); readers of bags that
//! `ros2 bag record` wrote must accept comments too, which is the reader's business, not ours.

/// `(type name as it appears inside definitions, definition text)` for every type we emit.
const DEFINITIONS: &[(&str, &str)] = &[
    ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n"),
    ("std_msgs/Header", "builtin_interfaces/Time stamp\nstring frame_id\n"),
    ("geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n"),
    ("geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n"),
    ("geometry_msgs/Quaternion", "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n"),
    ("geometry_msgs/Pose", "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n"),
    ("geometry_msgs/PoseStamped", "std_msgs/Header header\ngeometry_msgs/Pose pose\n"),
    ("geometry_msgs/PoseWithCovariance", "geometry_msgs/Pose pose\nfloat64[36] covariance\n"),
    ("geometry_msgs/Twist", "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n"),
    ("geometry_msgs/TwistWithCovariance", "geometry_msgs/Twist twist\nfloat64[36] covariance\n"),
    (
        "nav_msgs/Odometry",
        "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
    ),
    (
        "nav_msgs/MapMetaData",
        "builtin_interfaces/Time map_load_time\nfloat32 resolution\nuint32 width\nuint32 height\ngeometry_msgs/Pose origin\n",
    ),
    ("nav_msgs/OccupancyGrid", "std_msgs/Header header\nnav_msgs/MapMetaData info\nint8[] data\n"),
    ("rosgraph_msgs/Clock", "builtin_interfaces/Time clock\n"),
    (
        "nrslam_msgs/Detection",
        "float64 range_m\nfloat64 angle_rad\nfloat64 range_std_m\nfloat64 angle_std_rad\nfloat64 power_db\n",
    ),
    (
        "nrslam_msgs/Detections",
        "std_msgs/Header header\nfloat64 boresight_rad\nnrslam_msgs/Detection[] detections\n",
    ),
    (
        "nrslam_msgs/Keyframe",
        "std_msgs/Header header\nuint32 id\ngeometry_msgs/Pose pose\nfloat64 boresight_rad\nnrslam_msgs/Detection[] detections\n",
    ),
    (
        "nrslam_msgs/Segments",
        "std_msgs/Header header\nfloat64 eps_m\nuint32 min_samples\nuint32 cluster_count\ngeometry_msgs/Point[] points\nint32[] labels\n",
    ),
    (
        "nrslam_msgs/Target",
        "uint32 id\nstring shape\ngeometry_msgs/Point[] outline\ngeometry_msgs/Point[] samples\n",
    ),
    (
        "nrslam_msgs/RadarEcho",
        "std_msgs/Header header\nfloat64 boresight_rad\nfloat64 carrier_frequency_hz\nfloat64 subcarrier_spacing_hz\nfloat64 symbol_duration_s\nfloat64 antenna_spacing_wavelengths\nfloat64 snr_db\nuint32 antennas\nuint32 symbols\nuint32 subcarriers\nfloat64[] received\nfloat64[] transmitted\n",
    ),
    (
        "nrslam_msgs/RadarSpectrum",
        "std_msgs/Header header\nfloat64 boresight_rad\nfloat64 range_bin_m\nfloat64 antenna_spacing_wavelengths\nfloat64 noise_power\nuint32 range_bins\nuint32 angle_bins\nfloat64[] values\n",
    ),
    (
        "nrslam_msgs/KeyframePoses",
        "std_msgs/Header header\nuint32 revision\nuint32[] ids\ngeometry_msgs/Pose[] poses\nuint32[] loop_from_ids\nuint32[] loop_to_ids\ngeometry_msgs/Pose[] loop_relatives\nfloat64[] loop_informations\nfloat64[] pose_covariances\n",
    ),
    (
        "nrslam_msgs/AssociationStats",
        "std_msgs/Header header\nuint32 detections\nuint32 associated\nuint32 inliers\nfloat64 inlier_ratio\nfloat64 rms_residual_m\nstring icp_status\nuint32 icp_iterations\nfloat64 correction_m\nfloat64 correction_rad\nbool odometry_rejected\nint32 keyframe_id\nfloat64 keyframe_overlap\nbool loop_closed\nuint32 loop_closures\n",
    ),
    // The status levels (`byte OK=0` ...) are constants: they are left out, as they are of the
    // type hash, and a reader needs no constant to decode.
    ("diagnostic_msgs/KeyValue", "string key\nstring value\n"),
    (
        "diagnostic_msgs/DiagnosticStatus",
        "byte level\nstring name\nstring message\nstring hardware_id\ndiagnostic_msgs/KeyValue[] values\n",
    ),
    (
        "diagnostic_msgs/DiagnosticArray",
        "std_msgs/Header header\ndiagnostic_msgs/DiagnosticStatus[] status\n",
    ),
    // Standard types for real sensors and for viewers, as in ROS 2 Jazzy. PointField's and
    // Marker's constants are kept, so that the schema text equals what rosbags writes (a test
    // compares them); they are not fields, and the type hash leaves them out.
    (
        "sensor_msgs/PointField",
        "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\nuint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count\n",
    ),
    (
        "sensor_msgs/PointCloud2",
        "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\nbool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n",
    ),
    (
        "radar_msgs/RadarReturn",
        "float32 range\nfloat32 azimuth\nfloat32 elevation\nfloat32 doppler_velocity\nfloat32 amplitude\n",
    ),
    ("radar_msgs/RadarScan", "std_msgs/Header header\nradar_msgs/RadarReturn[] returns\n"),
    (
        "geometry_msgs/Transform",
        "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n",
    ),
    (
        "geometry_msgs/TransformStamped",
        "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n",
    ),
    ("tf2_msgs/TFMessage", "geometry_msgs/TransformStamped[] transforms\n"),
    ("nav_msgs/Path", "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses\n"),
    ("std_msgs/ColorRGBA", "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n"),
    ("builtin_interfaces/Duration", "int32 sec\nuint32 nanosec\n"),
    (
        "sensor_msgs/CompressedImage",
        "std_msgs/Header header\nstring format\nuint8[] data\n",
    ),
    ("visualization_msgs/UVCoordinate", "float32 u\nfloat32 v\n"),
    ("visualization_msgs/MeshFile", "string filename\nuint8[] data\n"),
    (
        "visualization_msgs/Marker",
        "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\nint32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\nint32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\nint32 ARROW_STRIP=12\nint32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\nstd_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\ngeometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\nbuiltin_interfaces/Duration lifetime\nbool frame_locked\ngeometry_msgs/Point[] points\nstd_msgs/ColorRGBA[] colors\nstring texture_resource\nsensor_msgs/CompressedImage texture\nvisualization_msgs/UVCoordinate[] uv_coordinates\nstring text\nstring mesh_resource\nvisualization_msgs/MeshFile mesh_file\nbool mesh_use_embedded_materials\n",
    ),
    ("visualization_msgs/MarkerArray", "visualization_msgs/Marker[] markers\n"),
    ("nrslam_msgs/TargetSet", "std_msgs/Header header\nnrslam_msgs/Target[] targets\n"),
    (
        "nrslam_msgs/MapTarget",
        "uint32 id\nstring shape\nfloat64 center_x_m\nfloat64 center_y_m\nfloat64 width_m\nfloat64 height_m\nfloat64 yaw_rad\nfloat64 radius_m\nfloat64[] covariance\nuint32 sides_seen\nuint32 updates\nfloat64 rms_residual_m\ngeometry_msgs/Point[] outline\ngeometry_msgs/Point[] samples\ngeometry_msgs/Point[] supporting_cells\n",
    ),
    ("nrslam_msgs/MapTargets", "std_msgs/Header header\nnrslam_msgs/MapTarget[] targets\n"),
    (
        "nrslam_msgs/Metrics",
        "std_msgs/Header header\nfloat64 etgospa\nfloat64 etgospa_localisation\nfloat64 etgospa_confusion\nfloat64 etgospa_missed\nfloat64 etgospa_false\nfloat64 gospa\nfloat64 gospa_localisation\nfloat64 gospa_missed\nfloat64 gospa_false\nfloat64 position_error_m\nuint32 estimated_targets\nuint32 estimate_points\n",
    ),
];

/// The short name used inside definitions: `nav_msgs/msg/OccupancyGrid` → `nav_msgs/OccupancyGrid`.
fn short_name(type_name: &str) -> String {
    type_name.replacen("/msg/", "/", 1)
}

fn definition(short: &str) -> Option<&'static str> {
    DEFINITIONS
        .iter()
        .find(|(name, _)| *name == short)
        .map(|(_, text)| *text)
}

/// Field types of a definition that are messages (contain a '/'), array suffixes removed.
fn message_field_types(text: &str) -> impl Iterator<Item = &str> {
    text.lines().filter_map(|line| {
        let field_type = line.split_whitespace().next()?;
        let base = field_type.split('[').next()?;
        base.contains('/').then_some(base)
    })
}

fn collect_dependencies(short: &str, seen: &mut Vec<String>) {
    let Some(text) = definition(short) else {
        return;
    };
    for dependency in message_field_types(text) {
        if !seen.iter().any(|s| s == dependency) {
            seen.push(dependency.to_owned());
            collect_dependencies(dependency, seen);
        }
    }
}

/// The full `ros2msg` schema of `type_name` (`pkg/msg/Type`), or `None` for a type we do not know.
pub fn ros2msg(type_name: &str) -> Option<String> {
    let short = short_name(type_name);
    let mut text = definition(&short)?.to_owned();
    let mut dependencies = Vec::new();
    collect_dependencies(&short, &mut dependencies);
    for dependency in dependencies {
        text.push_str(&"=".repeat(80));
        text.push('\n');
        text.push_str("MSG: ");
        text.push_str(&dependency);
        text.push('\n');
        text.push_str(definition(&dependency)?);
    }
    Some(text)
}

/// The bare definition (no dependencies) of a project type, as in `msgs/msg/<Type>.msg`.
pub fn definition_of(type_name: &str) -> Option<&'static str> {
    definition(&short_name(type_name))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn occupancy_grid_schema_matches_the_independent_reference() {
        let golden = include_str!("../tests/fixtures/nav_msgs_msg_OccupancyGrid.ros2msg");
        assert_eq!(ros2msg("nav_msgs/msg/OccupancyGrid").unwrap(), golden);
    }

    #[test]
    fn pose_stamped_schema_matches_the_independent_reference() {
        let golden = include_str!("../tests/fixtures/geometry_msgs_msg_PoseStamped.ros2msg");
        assert_eq!(ros2msg("geometry_msgs/msg/PoseStamped").unwrap(), golden);
    }

    #[test]
    fn every_dependency_of_every_definition_is_defined() {
        for (name, text) in DEFINITIONS {
            for dependency in message_field_types(text) {
                assert!(
                    definition(dependency).is_some(),
                    "{name} uses undefined {dependency}"
                );
            }
        }
    }

    #[test]
    fn project_msg_files_match_the_definitions() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("msg");
        let mut files = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let stem = path.file_stem().unwrap().to_str().unwrap().to_owned();
            let text = std::fs::read_to_string(&path).unwrap();
            let expected = definition(&format!("nrslam_msgs/{stem}")).unwrap();
            assert_eq!(text, expected, "{}", path.display());
            files += 1;
        }
        assert_eq!(
            files,
            DEFINITIONS
                .iter()
                .filter(|(n, _)| n.starts_with("nrslam_msgs/"))
                .count()
        );
    }

    #[test]
    fn unknown_type_has_no_schema() {
        assert!(ros2msg("foo_msgs/msg/Bar").is_none());
    }
}
