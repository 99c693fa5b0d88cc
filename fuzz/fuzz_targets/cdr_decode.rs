//! Arbitrary bytes as CDR payloads of every node message type: decode must return Ok or
//! an error, never panic or allocate without bound.
#![no_main]

use libfuzzer_sys::fuzz_target;

use crossym_io::bag::cdr::decode;
use crossym_io::msg;

fuzz_target!(|data: &[u8]| {
    let _ = decode::<msg::JointState>(data);
    let _ = decode::<msg::SymmetryCondition>(data);
    let _ = decode::<msg::Float64MultiArray>(data);
    let _ = decode::<msg::JointTrajectory>(data);
    let _ = decode::<msg::Status>(data);
});
