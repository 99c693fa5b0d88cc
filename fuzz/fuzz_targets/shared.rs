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
    /// The SQLite3 storage is not fuzzed here (the targets feed MCAP bytes to
    /// `Bag::from_bytes`; SQLite itself is fuzzed upstream): `Bag::open` of a `.db3` path,
    /// never called by the targets, reports it.
    pub mod sqlite {
        pub fn open(path: &std::path::Path) -> Result<super::reader::Bag, super::BagError> {
            Err(super::BagError::NotRos2 {
                path: path.to_path_buf(),
                message: "SQLite3 bags are not part of the fuzz build".into(),
            })
        }
    }
}
