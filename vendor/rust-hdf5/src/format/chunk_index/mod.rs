pub mod btree_v2;
pub mod extensible_array;
pub mod fixed_array;
