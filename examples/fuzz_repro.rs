//! Replays a saved fuzz input: `cargo run --example fuzz_repro TARGET FILE` (a panic
//! shows its message and location).
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let data = std::fs::read(&a[2]).expect("input file");
    println!("{:?}", rdr::robustness::run(&a[1], &data));
}
