//! The one closed loop ([`ClosedLoop`]): a plant, a navigation stage, a controller endpoint,
//! the metrics and the stop rules, stepped one control period at a time.
//!
//! - [`sim_loop`]: the loop itself; [`navigation`]: the navigation stages' trait and the
//!   truth path; [`estimator_nav`]: the vehicle's estimator on simulated sensors;
//!   [`endpoint`]: the controller end (the core in process); [`report`]: the summary, targets
//!   and verdicts; [`rules`]: the rules that judge a run; [`runner`]: a software run;
//!   [`lockstep`]: two runs stepped together (campaigns).

pub mod endpoint;
pub mod estimator_nav;
pub mod floor;
pub mod lockstep;
pub mod navigation;
pub mod report;
pub mod rules;
pub mod runner;
pub mod sim_loop;
pub mod smoother;

pub use endpoint::{ControllerEndpoint, CoreEndpoint, StepReply};
pub use navigation::{to_nav, FixRecord, Navigation, TruthNav};
pub use report::{
    figures, judge, ratio, verdict, verdict_word, NavReport, Rule, Summary, TargetCheck, Targets,
};
pub use rules::{still_growing, MAX_TURNS_OFF_PATH, RUNAWAY_M};
pub use sim_loop::*;
