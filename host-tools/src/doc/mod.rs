//! The documents and their typed parts: the floor every other layer stands
//! on. Nothing here reads a recording or runs a fit; every limit a document
//! is checked against lives beside the part it limits.
//!
//! * [`caldoc`]: the calibration document ([`CalDoc`]), its format and the
//!   checks of its coefficients ([`MAX_BIAS_ABS`], [`FIELD_NT_RANGE`],
//!   [`field_nt_problem`], the swing's and the model's);
//! * [`compass`]: the heading-only compass's document ([`CompassDoc`]) and
//!   [`Document`], a calibration document of either form;
//! * [`results`]: the `quality` and `trace` blocks and the session's summary
//!   ([`Quality`], [`SessionSummary`]);
//! * [`reference`](mod@reference): the independent reference a calibration is judged
//!   against and its check ([`Reference`], [`ReferenceCheck`]);
//! * [`auto`]: `fit --model auto`'s choice ([`AutoChoice`]) and its limit
//!   ([`MAX_HELD_OUT_DEG`]);
//! * [`integrity`]: a run's per-sample integrity counted
//!   ([`IntegrityCounts`]) and the "recalibrate" rule on them.

pub(crate) mod auto;
pub(crate) mod caldoc;
pub(crate) mod compass;
pub(crate) mod integrity;
pub(crate) mod reference;
pub(crate) mod results;

pub use auto::{AutoChoice, CandidateRow, HeldOutBasis, MAX_HELD_OUT_DEG};
pub use caldoc::{field_nt_problem, CalDoc, CalDocError, DocForm, FIELD_NT_RANGE, FORMAT_VERSION, MAX_BIAS_ABS};
pub use compass::{CompassDoc, Document};
pub use integrity::{IntegrityCounts, StateCounts};
pub use reference::{DipConstraint, Reference, ReferenceCheck, ReferenceSource};
pub use results::{Quality, SessionSummary};
pub use caldoc::model_kind;
pub use integrity::{integrity_text, recalibrate_text};
pub use reference::world_allowance;
pub use results::{BackstepMethod, JointEstimates, SessionSettings, SwingQuality};
