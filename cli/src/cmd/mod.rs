//! One module per subcommand.

pub mod diagram;
pub mod info;
pub mod mesh;
pub mod mesh_detail;
pub mod mesh_edit;
pub mod mesh_tiles;
pub mod mesh_tin;
pub mod rbf;
pub mod render;
pub mod report;
pub mod trace;
