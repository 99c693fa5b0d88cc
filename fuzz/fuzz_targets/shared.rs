// crossym's bag reader, CDR codec and ROS message types, from the crate's own files.
pub mod ros {
    #[path = "../../../src/ros/msg.rs"]
    pub mod msg;
}
pub mod bag {
    #[path = "../../../src/bag/cdr.rs"]
    pub mod cdr;
    #[path = "../../../src/bag/error.rs"]
    mod error;
    #[path = "../../../src/bag/reader.rs"]
    pub mod reader;
    pub use error::BagError;
}
