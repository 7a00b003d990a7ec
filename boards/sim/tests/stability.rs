//! The stability suite (`pocketsplat report stability`) as tests: one test per group, so a failure
//! names its group, and the message lists each failing case with its reason. Known failures pass
//! only while they reproduce exactly as documented (see `report::stability`).
//!
//! Run in the dev/test profile: overflow checks are part of what is tested.

use pocketsplat_sim::report::stability::{self, markdown, overflow_checks_on};

fn group(name: &str) {
    assert!(
        overflow_checks_on(),
        "the stability suite needs overflow checks (dev or test profile)"
    );
    let results = stability::run_group(name);
    assert!(!results.is_empty(), "group {name} has no cases");
    eprintln!("{}", markdown(&results));
    let failed: Vec<String> = results
        .iter()
        .filter(|c| !c.ok())
        .map(|c| format!("{}: {}", c.name, c.outcome.failures.join("; ")))
        .collect();
    assert!(
        failed.is_empty(),
        "{} of {} cases fail in group {name}:\n{}",
        failed.len(),
        results.len(),
        failed.join("\n")
    );
}

#[test]
fn camera_distances_from_0_001_to_10000_radii() {
    group("distance");
}

#[test]
fn inside_the_model_and_the_near_plane_through_it() {
    group("inside");
}

#[test]
fn fields_of_view_1_and_170_degrees() {
    group("fov");
}

#[test]
fn looking_along_each_axis_and_over_the_poles() {
    group("axes");
}

#[test]
fn scaled_and_translated_models_match_the_unit_model() {
    group("scale");
}

#[test]
fn depths_1_to_9() {
    group("depth");
}

#[test]
fn triangle_plane_needle_and_stiff_cluster() {
    group("shapes");
}

#[test]
fn lights_along_each_axis_and_grazing() {
    group("lights");
}

#[test]
fn frame_rate_controller_under_a_100x_cost_jump() {
    group("lod");
}
