//! Arbitrary bytes as an MCAP bag: `Bag::from_bytes` must return Ok or a BagError, never
//! panic; every message of a bag that opens is decoded as every node type (errors fine).
#![no_main]

use libfuzzer_sys::fuzz_target;

use crossym_io::bag::Bag;
use crossym_io::msg;

fuzz_target!(|data: &[u8]| {
    if let Ok(bag) = Bag::from_bytes(data, std::path::Path::new("fuzz.mcap")) {
        let _ = bag.info();
        for i in 0..bag.messages.len() {
            let _ = bag.decode::<msg::JointState>(i);
            let _ = bag.decode::<msg::SymmetryCondition>(i);
            let _ = bag.decode::<msg::Float64MultiArray>(i);
            let _ = bag.decode::<msg::JointTrajectory>(i);
            let _ = bag.decode::<msg::Status>(i);
        }
    }
});
