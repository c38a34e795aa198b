//! [`Keyed`]: the JSON objects of the summaries whose keys are computed.

use serde::Serialize;

/// A JSON object whose keys are computed (e.g. one entry per speed, `"35"`, `"36"`), in the
/// order given. `K`: the type of the keys, a string unless a study leaves the text of a
/// key to its caller (e.g. a configured speed, which the task writes as its JSON text).
#[derive(Debug, Clone, PartialEq)]
pub struct Keyed<T, K = String>(pub Vec<(K, T)>);

impl<T, K> Default for Keyed<T, K> {
    fn default() -> Self {
        Self(Vec::new())
    }
}

impl<T, K> Keyed<T, K> {
    /// No entries.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The same entries under the keys `key` makes of the old ones.
    pub fn rekeyed<L>(self, key: impl Fn(K) -> L) -> Keyed<T, L> {
        Keyed(self.0.into_iter().map(|(k, v)| (key(k), v)).collect())
    }
}

impl<T: Serialize, K: Serialize> Serialize for Keyed<T, K> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

impl<T, K> FromIterator<(K, T)> for Keyed<T, K> {
    fn from_iter<I: IntoIterator<Item = (K, T)>>(iter: I) -> Self {
        Self(iter.into_iter().collect())
    }
}
