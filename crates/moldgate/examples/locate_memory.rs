//! Who holds the heap at `locate`'s peak: a counting allocator that keeps the sizes of the
//! live blocks of 256 KiB and more, and a copy of that list each time the heap reaches a new
//! peak. Loads the part from its file as the command does (reopened handles), runs `locate`
//! with the given parting rule, and prints the peak with the large blocks live at it; then
//! the parting line alone, its own peak above what the loaded part holds. With `auto` for
//! the direction, the automatic choice with the gate located beside it, as the study runs
//! `--demold auto`. With `fill` or `walls` after the direction, the whole study with the
//! fill analysis or the wall thickness instead, and its peak.
//!
//! ```text
//! cargo run --release -p moldgate --example locate_memory -- PART.stl [+z|auto] [outline|longest|fill|walls]
//! ```

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::BufReader;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

use moldgate::mesh::{self, Units};
use moldgate::parting::{PartingLine, PartingRule};
use moldgate::thickness::Sampling;
use moldgate::undercut::auto_direction_beside_loaded;
use moldgate::{locate, Frame, LocateOptions};

/// Blocks at least this large are listed.
const LARGE: usize = 256 << 10;
/// At most this many large blocks are listed at once.
const SLOTS: usize = 256;

struct Counting;

static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static ENABLED: AtomicBool = AtomicBool::new(false);

/// The live large blocks (address, size) and their copy at the last peak. A fixed array
/// behind a mutex: the allocator must not allocate.
struct Blocks {
    live: [(usize, usize); SLOTS],
    at_peak: [(usize, usize); SLOTS],
}
static BLOCKS: Mutex<Blocks> = Mutex::new(Blocks {
    live: [(0, 0); SLOTS],
    at_peak: [(0, 0); SLOTS],
});

fn added(ptr: *mut u8, size: usize) {
    let now = CURRENT.fetch_add(size, Ordering::SeqCst) + size;
    let large = size >= LARGE && ENABLED.load(Ordering::Relaxed);
    if !large && now <= PEAK.load(Ordering::Relaxed) {
        return;
    }
    if let Ok(mut b) = BLOCKS.lock() {
        if large {
            if let Some(slot) = b.live.iter_mut().find(|s| s.1 == 0) {
                *slot = (ptr as usize, size);
            }
        }
        if now > PEAK.load(Ordering::SeqCst) {
            PEAK.store(now, Ordering::SeqCst);
            b.at_peak = b.live;
        }
    }
}

fn removed(ptr: *mut u8, size: usize) {
    CURRENT.fetch_sub(size, Ordering::SeqCst);
    if size >= LARGE {
        if let Ok(mut b) = BLOCKS.lock() {
            if let Some(slot) = b.live.iter_mut().find(|s| s.0 == ptr as usize) {
                *slot = (0, 0);
            }
        }
    }
}

// SAFETY: every call is passed on to `System` unchanged; only counts are kept beside it.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's layout contract is passed on.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            added(p, layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as in `alloc`.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            added(p, layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        removed(ptr, layout.size());
        // SAFETY: `ptr` came from `System` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: `ptr` came from `System` with this layout.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            removed(ptr, layout.size());
            added(p, new_size);
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

fn mib(b: usize) -> f64 {
    b as f64 / (1 << 20) as f64
}

/// Starts a new peak from what is live now.
fn reset() -> usize {
    let now = CURRENT.load(Ordering::SeqCst);
    PEAK.store(now, Ordering::SeqCst);
    if let Ok(mut b) = BLOCKS.lock() {
        b.at_peak = b.live;
    }
    now
}

fn report(what: &str, base: usize) {
    let peak = PEAK.load(Ordering::SeqCst);
    let mut sizes: Vec<usize> = BLOCKS
        .lock()
        .map(|b| b.at_peak.iter().map(|s| s.1).filter(|&s| s > 0).collect())
        .unwrap_or_default();
    sizes.sort_unstable_by(|a, b| b.cmp(a));
    println!(
        "{what}: heap peak {:.2} MiB ({:.2} MiB above the {:.2} MiB before it); large blocks live at the peak ({:.2} MiB):",
        mib(peak),
        mib(peak - base),
        mib(base),
        mib(sizes.iter().sum())
    );
    for s in sizes {
        println!("  {:>10} bytes  {:.2} MiB", s, mib(s));
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: locate_memory PART.stl [DEMOLD] [outline|longest]");
        std::process::exit(2);
    };
    let auto = args.get(1).is_some_and(|a| a == "auto");
    let direction = match auto {
        true => "+z",
        false => args.get(1).map_or("+z", String::as_str),
    }
    .parse()
    .expect("demold");
    let parting = match args.get(2).map(String::as_str) {
        Some("longest") => PartingRule::Longest,
        _ => PartingRule::Outline,
    };
    ENABLED.store(true, Ordering::SeqCst);
    let len = std::fs::metadata(path).expect("the part").len();
    let open = || std::fs::File::open(path).map(|f| BufReader::with_capacity(1 << 16, f));
    let part = mesh::read_stl_reopen(open, len, Units::Mm).expect("load");
    report("load", 0);
    if let Some(what @ ("fill" | "walls")) = args.get(2).map(String::as_str) {
        let options = moldgate::StudyOptions {
            demold: args.get(1).map_or("+z", String::as_str).into(),
            fill: what == "fill",
            wall_thickness: what == "walls",
            ..Default::default()
        };
        let base = reset();
        let study = moldgate::study(&part, &options).expect("study");
        report(&format!("the study with {what}"), base);
        drop(study);
        return;
    }
    let mut options = LocateOptions {
        direction,
        parting,
        ..LocateOptions::default()
    };
    if auto {
        let base = reset();
        let along = |d| {
            let o = LocateOptions {
                direction: d,
                ..options.clone()
            };
            locate(&part, &o)
        };
        let (choice, _) =
            auto_direction_beside_loaded(&part, Sampling::Centroid, along, |_, _| true)
                .expect("auto");
        report("the automatic direction, the gate located beside", base);
        options.direction = choice.direction();
    }
    let direction = options.direction;
    let base = reset();
    let analysis = locate(&part, &options).expect("locate");
    report("locate", base);
    drop(analysis);
    let base = reset();
    let line = PartingLine::outline(&part.mesh, &part.topology, &Frame::new(direction));
    report("the outline rule alone", base);
    println!(
        "file {:.2} MiB, {} vertices, {} triangles, parting line {:.1} mm",
        mib(len as usize),
        part.mesh.vertices.len(),
        part.mesh.triangles.len(),
        line.length_mm
    );
}
