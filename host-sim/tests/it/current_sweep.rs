//! The current sweep (the measurement) computes real runs and draws them: a cell is a
//! closed-loop run in the given current, and the files are written.

use host_sim::commands::current_sweep::{cell, write, RMS_BOUND_M};

#[test]
fn a_light_current_from_the_side_is_tracked_and_the_sweep_files_are_written() {
    let light = cell("circle-3d", 0.1, 90.0).unwrap();
    let still = cell("circle-3d", 0.0, 90.0).unwrap();
    eprintln!("{light:?}\n{still:?}");
    assert!(!light.nan && light.rms_last80_m <= RMS_BOUND_M, "{light:?}");
    // The current is really there: it costs error against still water.
    assert!(
        light.rms_last80_m > still.rms_last80_m,
        "{light:?} vs {still:?}"
    );
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("current-sweep");
    write(&dir, &[light, still]).unwrap();
    for f in ["sweep.csv", "sweep.json", "heatmap_circle-3d.png"] {
        assert!(dir.join(f).is_file(), "{f}");
    }
}
