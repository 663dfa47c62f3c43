//! rosbag2 folders: `metadata.yaml` and one or more storage files (MCAP or sqlite3) of CDR
//! messages.

pub mod metadata;
pub mod schemas;
pub mod storage;
