//! Layer 2, the bus: the iceoryx2 wiring every process shares, the set's table
//! (which process publishes and subscribes to what), timing, and the allocation
//! counter that proves the filter loop allocation-free.

pub mod alloc_count;
pub mod timing;
pub mod topology;
pub mod wiring;
