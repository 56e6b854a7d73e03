//! launch/standard-input.toml on bags written by other tools (rosbags and the mcap package,
//! tests/fixtures/ros2/bags): an AGV driving along y = 0 from x = 0 to 9.5 m with a radar looking
//! left at a wall y = 8 m, 0 ≤ x ≤ 30 m. The back end must map the wall where the radar saw it
//! (within 20 m and ±60° of the boresight: 0 ≤ x ≤ 23.4 m) and nothing elsewhere.

mod common;

use common::*;
use nrslam_msgs::{Message, OccupancyGrid};
use nrslam_runtime::bag::{Bag, ReadMode};
use std::path::Path;

/// Copies a fixture bag into a fresh folder, so the run cannot touch the fixture.
fn copy_bag(name: &str) -> tempfile::TempDir {
    let dir = temp();
    let from = root().join("tests/fixtures/ros2/bags").join(name);
    for entry in std::fs::read_dir(&from).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, dir.path().join(path.file_name().unwrap())).unwrap();
    }
    dir
}

/// The last /map of a recorded run.
fn last_map(recorded: &Path) -> OccupancyGrid {
    let bag = Bag::open(recorded, ReadMode::Strict).unwrap();
    let mut last = None;
    for message in bag.messages_on(&["/map".to_owned()]).unwrap() {
        match message.unwrap().decode().unwrap() {
            Message::OccupancyGrid(grid) => last = Some(grid),
            other => panic!("/map carried {}", other.type_name()),
        }
    }
    last.expect("the run published a map")
}

/// Centres (x m, y m) of the cells at or above 65 % (the segmenter's occupied threshold).
fn occupied_cells(grid: &OccupancyGrid) -> Vec<(f64, f64)> {
    let (x0, y0, yaw) = grid.info.origin.planar();
    assert_eq!(yaw, 0.0);
    let resolution = f64::from(grid.info.resolution);
    let width = grid.info.width as usize;
    grid.data
        .iter()
        .enumerate()
        .filter(|(_, &v)| v >= 65)
        .map(|(i, _)| {
            let (column, row) = (i % width, i / width);
            (
                x0 + (column as f64 + 0.5) * resolution,
                y0 + (row as f64 + 0.5) * resolution,
            )
        })
        .collect()
}

/// Runs the launch file on `bag` with `args`, recording /map, and checks the wall.
fn maps_the_wall(bag: &str, args: &[&str]) {
    let bag = copy_bag(bag);
    let out = temp();
    let recorded = out.path().join("rec");
    let bag_arg = format!("bag:={}", bag.path().display());
    let mut all = vec![
        "launch",
        "launch/standard-input.toml",
        bag_arg.as_str(),
        "--out",
        out.path().to_str().unwrap(),
        "--record",
        recorded.to_str().unwrap(),
    ];
    all.extend_from_slice(args);
    run_ok(&all);
    let cells = occupied_cells(&last_map(&recorded));
    // Every occupied cell is on the wall: the fixture has nothing else and the poses are exact.
    let off_wall: Vec<_> = cells
        .iter()
        .filter(|(_, y)| (y - 8.0).abs() > 0.25)
        .collect();
    assert!(off_wall.is_empty(), "occupied off the wall: {off_wall:?}");
    // The wall is mapped along all the radar saw: every metre of 0 ≤ x ≤ 23 holds a wall cell.
    for metre in 0..23 {
        let lo = f64::from(metre);
        assert!(
            cells.iter().any(|&(x, _)| x >= lo && x < lo + 1.0),
            "no wall cell in {lo} ≤ x < {} m; occupied: {cells:?}",
            lo + 1.0
        );
    }
    assert!(
        cells.iter().all(|&(x, _)| (-0.25..=30.25).contains(&x)),
        "{cells:?}"
    );
}

#[test]
fn radar_scans_of_a_rosbags_bag_map_the_wall() {
    maps_the_wall("v9_plain", &[]);
}

#[test]
fn point_clouds_of_a_split_lz4_bag_map_the_wall() {
    // The fixture's points are (x, y) in the AGV's axes (make_bags.py writes r·cos(a + π/2),
    // r·sin(a + π/2)) while its RadarScan azimuths are from the boresight +y: the two topics'
    // "radar" frames differ by π/2, so the cloud's mounting yaw is 0.
    maps_the_wall("v9_lz4_split", &["input:=point_cloud2", "yaw_rad:=0"]);
}

#[test]
fn zstd_bag_with_viz_off_maps_the_wall() {
    maps_the_wall("v9_zstd", &["viz:=false"]);
}

#[test]
fn a_mounting_pose_that_disagrees_with_the_bag_puts_the_wall_elsewhere() {
    // The same returns with the radar declared looking right: the wall lands at y = −8 m.
    let bag = copy_bag("v9_plain");
    let out = temp();
    let recorded = out.path().join("rec");
    let bag_arg = format!("bag:={}", bag.path().display());
    run_ok(&[
        "launch",
        "launch/standard-input.toml",
        &bag_arg,
        "yaw_rad:=-1.5707963267948966",
        // The default grid starts at y = −3 m; a node-parameter override moves it.
        "mapper.origin_y_m:=-12",
        "--out",
        out.path().to_str().unwrap(),
        "--record",
        recorded.to_str().unwrap(),
    ]);
    let cells = occupied_cells(&last_map(&recorded));
    assert!(!cells.is_empty());
    assert!(
        cells.iter().all(|(_, y)| (y + 8.0).abs() <= 0.25),
        "{cells:?}"
    );
}
