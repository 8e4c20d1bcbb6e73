//! Serde for fixed arrays longer than serde's own 32 (`#[serde(with =
//! "hob_gearing::serde_arrays")]`): a sequence of exactly N elements. The control core's
//! state (a program's passes, the event ring, a contour's points) is saved whole in a
//! flight record (`hob replay`).

use serde::de::{Error, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::marker::PhantomData;

pub fn serialize<S: Serializer, T: Serialize, const N: usize>(a: &[T; N], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(a.iter())
}

pub fn deserialize<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    struct V<T, const N: usize>(PhantomData<T>);
    impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for V<T, N> {
        type Value = [T; N];
        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "an array of {N} elements")
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<[T; N], A::Error> {
            let mut v = Vec::with_capacity(N);
            while let Some(x) = seq.next_element()? {
                if v.len() == N {
                    return Err(A::Error::invalid_length(N + 1, &self));
                }
                v.push(x);
            }
            v.try_into()
                .map_err(|v: Vec<T>| A::Error::invalid_length(v.len(), &self))
        }
    }
    d.deserialize_seq(V::<T, N>(PhantomData))
}
