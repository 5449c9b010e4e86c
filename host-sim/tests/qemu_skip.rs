//! A machine without the thumbv7em target (or without QEMU) skips the emulated-board tests
//! with the reason and the fix instead of failing the build; with `ROV_REQUIRE_QEMU` (CI) the
//! same situation is an error. The toolchain is faked with a `RUSTC` whose sysroot lacks the
//! target (this test binary holds only this test, so setting the variables races nothing).

use host_sim::tether::qemu::{
    firmware_target_installed, image_or_skip, layout_images_or_skip, qemu_firmware_image,
    qemu_layout_images, workspace_root, FirmwareImage, LayoutImages,
};
use std::path::PathBuf;

#[test]
fn missing_target_is_a_skip_with_the_fix_or_an_error_in_ci() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fake-toolchain");
    let sysroot = dir.join("sysroot");
    std::fs::create_dir_all(sysroot.join("lib/rustlib/x86_64-unknown-linux-gnu")).unwrap();
    let rustc = dir.join("rustc");
    std::fs::write(&rustc, format!("#!/bin/sh\necho {}\n", sysroot.display())).unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&rustc, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    std::env::set_var("RUSTC", &rustc);
    std::env::remove_var("HIL_FIRMWARE_ELF");
    let root = workspace_root();
    assert!(!firmware_target_installed(&root));
    match qemu_firmware_image(&root).unwrap() {
        FirmwareImage::Unavailable(why) => {
            assert!(why.contains("fix: "), "{why}");
            assert!(
                why.contains("rustup target add thumbv7em-none-eabihf")
                    || why.contains("apt-get install -y qemu-system-arm"),
                "{why}"
            );
        }
        FirmwareImage::Ready(p) => panic!("built {} without the target", p.display()),
    }
    // The topside layout's two images (tests/deployment_qemu.rs) take the same path.
    match qemu_layout_images(&root).unwrap() {
        LayoutImages::Unavailable(why) => assert!(why.contains("fix: "), "{why}"),
        LayoutImages::Ready(e) => panic!("built {e:?} without the target"),
    }
    std::env::remove_var("ROV_REQUIRE_QEMU");
    assert_eq!(image_or_skip().unwrap(), None, "a developer machine skips");
    assert_eq!(layout_images_or_skip().unwrap(), None);
    std::env::set_var("ROV_REQUIRE_QEMU", "1");
    let e = image_or_skip().unwrap_err().to_string();
    assert!(e.contains("ROV_REQUIRE_QEMU"), "{e}");
    let e = layout_images_or_skip().unwrap_err().to_string();
    assert!(e.contains("ROV_REQUIRE_QEMU"), "{e}");
}
