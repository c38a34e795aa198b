//! Parallel maps with the work as a `&dyn Fn`: rayon's machinery compiled once per item
//! and result type, not once per call site and plant.
//!
//! A closure written inside a function that is generic over the plant (every study below
//! `trailer_model::with_plant!`) is a new type for each plant the function is compiled
//! for, and a rayon pipeline over it compiles its splitting machinery (producers, bridges,
//! `join`, stack jobs) again for each — eight plants × every call site: a quarter of the
//! task layer's compiled code in the test build. Here the work is a
//! `&dyn Fn` and each result goes to its own slot, so the one rayon pipeline underneath
//! has no type parameters and is compiled once; the indirect call and the slot's lock
//! per item cost nothing next to an item's work (a continuation, a simulation, a root
//! count).
//!
//! Results are in item order on any number of threads; [`try_map`] returns the first
//! error in item order (every item is evaluated), so a failure reads the same however the
//! items were scheduled.
//!
//! ```
//! use sway_model::parallel::{Split, try_map};
//! let squares = try_map(&[1.0, 2.0, 3.0], Split::Adaptive, &|_, &x: &f64| {
//!     if x > 0.0 { Ok(x * x) } else { Err("negative") }
//! });
//! assert_eq!(squares, Ok(vec![1.0, 4.0, 9.0]));
//! ```

use std::sync::Mutex;

use rayon::prelude::*;

/// How the items are split among rayon's threads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Split {
    /// rayon's adaptive splitting (many items of similar cost)
    #[default]
    Adaptive,
    /// one item per task: few long items of uneven cost, none waits behind a group that a
    /// busy thread holds
    OnePerTask,
}

/// The number of threads the parallel maps run on (rayon's global pool: the cores, or
/// `RAYON_NUM_THREADS`).
pub fn threads() -> usize {
    rayon::current_num_threads()
}

/// `f(k, &items[k])` for every item, in parallel; the results in item order.
pub fn map<T: Sync, U: Send>(
    items: &[T],
    split: Split,
    f: &(dyn Fn(usize, &T) -> U + Sync),
) -> Vec<U> {
    map_indices(items.len(), split, &|k| f(k, &items[k]))
}

/// `f(k)` for k = 0 … n − 1, in parallel; the results in index order.
pub fn map_indices<U: Send>(n: usize, split: Split, f: &(dyn Fn(usize) -> U + Sync)) -> Vec<U> {
    let slots: Vec<Mutex<Option<U>>> = (0..n).map(|_| Mutex::new(None)).collect();
    for_each_index(n, split, &|k| {
        let u = f(k);
        *lock(&slots[k]) = Some(u);
    });
    slots.into_iter().map(filled).collect()
}

/// [`map`] of a fallible `f`: every result in item order, or the first error in item order.
///
/// # Errors
/// The first item's error, in item order.
pub fn try_map<T: Sync, U: Send, E: Send>(
    items: &[T],
    split: Split,
    f: &(dyn Fn(usize, &T) -> Result<U, E> + Sync),
) -> Result<Vec<U>, E> {
    map(items, split, f).into_iter().collect()
}

/// `(a(), b())`, the two run in parallel ([`rayon::join`]).
pub fn join<A: Send, B: Send>(a: &(dyn Fn() -> A + Sync), b: &(dyn Fn() -> B + Sync)) -> (A, B) {
    let (ra, rb) = (Mutex::new(None), Mutex::new(None));
    join_erased(&|| *lock(&ra) = Some(a()), &|| *lock(&rb) = Some(b()));
    (filled(ra), filled(rb))
}

/// The one rayon pipeline of this module (no type parameters: compiled once): `f(k)` for
/// k = 0 … n − 1 in parallel.
fn for_each_index(n: usize, split: Split, f: &(dyn Fn(usize) + Sync)) {
    let indices = (0..n).into_par_iter();
    // a cancelled computation stops before its next item (`cancel::run` catches it)
    let item = |k| {
        cancel::checkpoint();
        f(k);
    };
    match split {
        Split::Adaptive => indices.for_each(item),
        Split::OnePerTask => indices.with_max_len(1).for_each(item),
    }
}

/// [`rayon::join`] of two type-erased halves (compiled once).
fn join_erased(a: &(dyn Fn() + Sync), b: &(dyn Fn() + Sync)) {
    rayon::join(a, b);
}

/// The value of a slot that the pipeline filled (every slot is filled before it returns).
fn filled<U>(slot: Mutex<Option<U>>) -> U {
    slot.into_inner()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
        .expect("the parallel pipeline fills every slot before it returns")
}

/// The slot behind `m`; a panic while it was held is rayon's to propagate, not ours.
fn lock<U>(m: &Mutex<U>) -> std::sync::MutexGuard<'_, U> {
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference: the sequential map and the halves run alone; the first error in item
    /// order whatever the threads.
    #[test]
    fn maps_and_joins_in_order_and_reports_the_first_error_in_order() {
        let items: Vec<u64> = (0..1000).collect();
        let expected: Vec<u64> = items.iter().map(|k| k * k + 1).collect();
        for split in [Split::Adaptive, Split::OnePerTask] {
            for threads in [1, 2, 5] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let got = pool.install(|| map(&items, split, &|k, &x| x * x + 1 + k as u64 - x));
                assert_eq!(got, expected);
                let by_index =
                    pool.install(|| map_indices(items.len(), split, &|k| items[k] * items[k] + 1));
                assert_eq!(by_index, expected);
                let failed = pool.install(|| {
                    try_map(&items, split, &|_, &x| {
                        if x % 97 == 13 { Err(x) } else { Ok(x) }
                    })
                });
                assert_eq!(failed, Err(13));
                let (left, right) = pool.install(|| {
                    join(&|| items.iter().sum::<u64>(), &|| {
                        format!("{}", items.len())
                    })
                });
                assert_eq!((left, right.as_str()), (499_500, "1000"));
            }
        }
    }
}
