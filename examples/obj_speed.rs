//! OBJ reader speed: `cargo run --release --example obj_speed -- MESH.obj [RUNS]`
//! prints the best of RUNS (default 5) one-thread CPU times (Linux schedstat) of the
//! fast reader and one of the reference reader, with MB/s.

/// As in the `rdr` binary: large blocks advised for huge pages, so the reader's arrays
/// fault in as they do there.
#[global_allocator]
static ALLOCATOR: rdr::HugePageAllocator = rdr::HugePageAllocator;

fn cpu_seconds() -> f64 {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap_or_default();
    s.split_whitespace().next().and_then(|w| w.parse::<u64>().ok()).unwrap_or(0) as f64 * 1e-9
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).expect("usage: obj_speed MESH.obj [RUNS]");
    let runs: usize = args.get(2).and_then(|r| r.parse().ok()).unwrap_or(5);
    let bytes = std::fs::read(path).expect("cannot read the mesh");
    let mb = bytes.len() as f64 / 1e6;
    let time = |f: &dyn Fn() -> usize, runs: usize| {
        let mut best = f64::INFINITY;
        let mut n = 0;
        for _ in 0..runs {
            let c0 = cpu_seconds();
            n = f();
            best = best.min(cpu_seconds() - c0);
        }
        (best, n)
    };
    let (fast, n) = time(&|| rdr::geometry::obj::parse_bytes(&bytes).unwrap().triangles.len(), runs);
    println!(
        "parse_bytes      {:7.1} ms  {:6.0} MB/s  ({n} triangles, {mb:.1} MB, best of {runs})",
        fast * 1e3,
        mb / fast
    );
    let (slow, _) = time(
        &|| {
            rdr::geometry::obj::parse_reference(&String::from_utf8_lossy(&bytes))
                .unwrap()
                .triangles
                .len()
        },
        1,
    );
    println!("parse_reference  {:7.1} ms  {:6.0} MB/s", slow * 1e3, mb / slow);
}
