//! The built-in scenarios, embedded from `scenarios/`.

/// A built-in scenario: its name and TOML text, embedded in the binary.
#[derive(Debug, Clone, Copy)]
pub struct BuiltIn {
    /// Name (the file stem).
    pub name: &'static str,
    /// TOML text.
    pub toml: &'static str,
}

macro_rules! builtin {
    ($name:literal) => {
        BuiltIn {
            name: $name,
            toml: include_str!(concat!("../../scenarios/", $name, ".toml")),
        }
    };
}

/// Every built-in scenario, in the order the no-argument run uses.
pub const BUILT_IN: &[BuiltIn] = &[
    builtin!("paper-xz"),
    builtin!("paper-xy"),
    builtin!("paper-xz-saturated"),
    builtin!("paper-xy-saturated"),
    builtin!("tracking-xz"),
    builtin!("tracking-xy"),
    builtin!("circle-3d"),
    builtin!("lawnmower-3d"),
    builtin!("helix-3d"),
    builtin!("current-3d"),
    builtin!("line-3d"),
    builtin!("current-line-behind-3d"),
    builtin!("current-line-cross-3d"),
    builtin!("current-hold-end-3d"),
    builtin!("delay-line-3d"),
    builtin!("mc-circle-3d"),
    builtin!("nav-circle-3d"),
    builtin!("nav-lawnmower-3d"),
    builtin!("nav-current-3d"),
    builtin!("nav-usbl-circle-3d"),
    builtin!("nav-usbl-current-3d"),
    builtin!("nav-usbl-outliers-3d"),
    builtin!("nav-usbl-dropout-3d"),
];
