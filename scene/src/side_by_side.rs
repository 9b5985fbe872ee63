//! One TOML table that holds several types' keys side by side — a scene's `[feedback]`
//! (the controller's `Weights` and `Config`), a commissioning file's `[[drive]]` row (its
//! own keys, the drive's `DriveSetup` and `MotionWindows`) and `[inclinometer]` (its own
//! keys, the sensor's `InclinometerSetup` and `LateralAxis`) — read into each type with
//! every key's place in the file kept: a bad value is refused at its key, a typo with
//! every key the table has, as when the table is one type. serde's `flatten` would buffer the inner type's
//! keys without their places and drop the list of keys a typo could have meant.

use std::ops::Range;

use serde::de::{self, Deserialize, Visitor};
use toml::de::{DeTable, DeValue, ValueDeserializer};
use toml::Spanned;

use crate::{key_at, refuse, SceneError};

/// `table`'s keys split into `A`'s and `B`'s (the names their derives read); a key
/// neither reads is refused at its place with serde's message for an unknown field,
/// listing `A`'s keys, then `B`'s.
pub(crate) fn split<'i, A: Deserialize<'i>, B: Deserialize<'i>>(
    text: &str,
    table: DeTable<'i>,
) -> Result<(DeTable<'i>, DeTable<'i>), SceneError> {
    let [a, b] = split_among(text, table, [field_names::<A>(), field_names::<B>()])?;
    Ok((a, b))
}

/// [`split`] for three types' keys side by side (a commissioning file's `[[drive]]` row:
/// its own keys, the drive's `DriveSetup` and its `MotionWindows`).
pub(crate) fn split3<'i, A: Deserialize<'i>, B: Deserialize<'i>, C: Deserialize<'i>>(
    text: &str,
    table: DeTable<'i>,
) -> Result<(DeTable<'i>, DeTable<'i>, DeTable<'i>), SceneError> {
    let [a, b, c] = split_among(
        text,
        table,
        [field_names::<A>(), field_names::<B>(), field_names::<C>()],
    )?;
    Ok((a, b, c))
}

/// `table`'s keys split by the lists `keys` (one per type, a key to the first list that
/// names it); a key no list names is refused, listing every list's keys in order.
fn split_among<'i, const N: usize>(
    text: &str,
    table: DeTable<'i>,
    keys: [&'static [&'static str]; N],
) -> Result<[DeTable<'i>; N], SceneError> {
    let mut tables = [(); N].map(|()| DeTable::new());
    for (key, value) in table {
        if let Some(i) = keys
            .iter()
            .position(|list| list.contains(&key.get_ref().as_ref()))
        {
            if let Some(t) = tables.get_mut(i) {
                t.insert(key, value);
            }
        } else {
            let expected: Vec<String> = keys
                .iter()
                .flat_map(|list| list.iter())
                .map(|k| format!("`{k}`"))
                .collect();
            return Err(refuse(
                &key_at(text, key.span().start),
                format!(
                    "unknown field `{}`, expected one of {}",
                    key.get_ref(),
                    expected.join(", ")
                ),
            ));
        }
    }
    Ok(tables)
}

/// `T` from its keys `table` (of the table at `span` in `text`), an error named at the
/// key it stands at.
pub(crate) fn read<'i, T: Deserialize<'i>>(
    text: &str,
    span: Range<usize>,
    table: DeTable<'i>,
) -> Result<T, SceneError> {
    T::deserialize(ValueDeserializer::from(Spanned::new(
        span,
        DeValue::Table(table),
    )))
    .map_err(|e| {
        let field = e.span().map(|s| key_at(text, s.start)).unwrap_or_default();
        refuse(&field, e.message())
    })
}

/// The keys serde's derive reads for `T` (the `fields` it hands the deserializer), in
/// their order in `T`.
fn field_names<'de, T: Deserialize<'de>>() -> &'static [&'static str] {
    /// A deserializer that only notes the fields it is asked for.
    struct Fields<'a>(&'a mut &'static [&'static str]);
    impl<'de> de::Deserializer<'de> for Fields<'_> {
        type Error = de::value::Error;
        fn deserialize_any<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value, Self::Error> {
            Err(de::Error::custom("not a struct"))
        }
        fn deserialize_struct<V: Visitor<'de>>(
            self,
            _name: &'static str,
            fields: &'static [&'static str],
            _visitor: V,
        ) -> Result<V::Value, Self::Error> {
            *self.0 = fields;
            Err(de::Error::custom("fields noted"))
        }
        serde::forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes
            byte_buf option unit unit_struct newtype_struct seq tuple tuple_struct map enum
            identifier ignored_any
        }
    }
    let mut fields: &'static [&'static str] = &[];
    // It always fails: it only notes the fields.
    let _ = T::deserialize(Fields(&mut fields));
    fields
}
