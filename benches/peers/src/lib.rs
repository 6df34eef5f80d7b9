//! Peer comparison benchmarks live in benches/peers.rs.
