//! The scene file's schema: the serde types a scene TOML is parsed into before any value is
//! checked (see [`super::resolve`] for the ranges and the geometry checks).
//!
//! Every value that an error may have to point at is a [`Spanned`] one, so that the message
//! names its line. A `[[mesh]]` entry is one of four kinds ([`MeshKind`]: `quad`, `box`,
//! `icosphere`, `file`), each a struct with `deny_unknown_fields`: a key that does not belong to
//! the entry's kind (`radius` on a quad, `size` on a file mesh) is refused by the toml crate at
//! that key's line. The kind's tag is `primitive = "quad" | "box" | "icosphere"`, or the
//! presence of `file`. Serde's internally tagged enums buffer the table and lose the spans, so
//! the entry is handed to the derived, externally tagged [`MeshKind`] as `{ quad = <entry
//! without its primitive key> }`, which keeps every span.

use serde::Deserialize;
use std::borrow::Cow;
use std::ops::Range;
use toml::de::{DeTable, DeValue, ValueDeserializer};
use toml::Spanned;

use super::Emission;

/// The whole file, as the toml crate deserializes it in one pass. The mesh entries are only
/// read for their kind here ([`MeshHead`]); [`parse`] deserializes each into its kind.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SceneFile {
    #[serde(default)]
    pub name: Option<String>,
    #[serde(default)]
    pub eta: Option<Spanned<f64>>,
    pub laser: Spanned<LaserEntry>,
    pub camera: Spanned<CameraEntry>,
    #[serde(default)]
    pub mesh: Vec<Spanned<MeshHead>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LaserEntry {
    pub position_m: Spanned<[f64; 3]>,
    pub normal: Spanned<[f64; 3]>,
    #[serde(default)]
    pub emission: Option<Emission>,
    pub wavelength_nm: Spanned<f64>,
    pub pulse_width_fs: Spanned<f64>,
    pub energy: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CameraEntry {
    pub position_m: Spanned<[f64; 3]>,
    pub look_at_m: Spanned<[f64; 3]>,
    #[serde(default)]
    pub up: Option<Spanned<[f64; 3]>>,
    pub vfov_deg: Spanned<f64>,
    pub nx: Spanned<usize>,
    pub ny: Spanned<usize>,
    pub nt: Spanned<usize>,
    pub dt_ps: Spanned<f64>,
    pub t0_ps: Spanned<f64>,
}

/// The built-in primitives a mesh entry may name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(super) enum Primitive {
    Quad,
    Box,
    Icosphere,
}

impl Primitive {
    /// The name of the primitive in a scene file (and of its [`MeshKind`] variant).
    fn as_str(self) -> &'static str {
        match self {
            Primitive::Quad => "quad",
            Primitive::Box => "box",
            Primitive::Icosphere => "icosphere",
        }
    }
}

/// The two keys of a mesh entry that decide its kind (the other keys are read by
/// [`MeshKind`]).
#[derive(Deserialize)]
pub(super) struct MeshHead {
    #[serde(default)]
    pub primitive: Option<Spanned<Primitive>>,
    #[serde(default)]
    pub file: Option<Spanned<String>>,
}

/// Declares the struct of one mesh kind: its own keys, then the keys that every entry shares
/// (label, placement and material), so that `deny_unknown_fields` knows all of them and the
/// toml crate lists them when it refuses another. The struct converts into a [`MeshEntry`].
macro_rules! mesh_kind {
    ($(#[$meta:meta])* $name:ident => $shape:ident { $($(#[$fmeta:meta])* $field:ident: $ty:ty,)* }) => {
        $(#[$meta])*
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        pub(super) struct $name {
            #[serde(default)]
            name: Option<String>,
            $($(#[$fmeta])* $field: $ty,)*
            #[serde(default)]
            scale: Option<Spanned<f64>>,
            #[serde(default)]
            rotate_deg: Option<Spanned<[f64; 3]>>,
            #[serde(default)]
            rotate_axis: Option<Spanned<[f64; 3]>>,
            #[serde(default)]
            rotate_angle_deg: Option<Spanned<f64>>,
            #[serde(default)]
            translate_m: Option<Spanned<[f64; 3]>>,
            albedo: Spanned<f64>,
        }

        impl From<$name> for MeshEntry {
            fn from(e: $name) -> MeshEntry {
                MeshEntry {
                    name: e.name,
                    shape: Shape::$shape { $($field: e.$field,)* },
                    placement: Placement {
                        scale: e.scale,
                        rotate_deg: e.rotate_deg,
                        rotate_axis: e.rotate_axis,
                        rotate_angle_deg: e.rotate_angle_deg,
                        translate_m: e.translate_m,
                    },
                    albedo: e.albedo,
                }
            }
        }
    };
}

mesh_kind!(
    /// `primitive = "quad"`: a rectangle `size = [x, y]` in the z = 0 plane, normal +z.
    QuadEntry => Quad { size: Spanned<Vec<f64>>, }
);
mesh_kind!(
    /// `primitive = "box"`: a box `size = [x, y, z]` centred on the origin.
    BoxEntry => Box { size: Spanned<Vec<f64>>, }
);
mesh_kind!(
    /// `primitive = "icosphere"`: a sphere of `radius`, `subdivisions` (default 3) times
    /// refined.
    IcosphereEntry => Icosphere {
        radius: Spanned<f64>,
        #[serde(default)]
        subdivisions: Option<Spanned<u32>>,
    }
);
mesh_kind!(
    /// `file = "..."`: a mesh file relative to the scene file's folder, optionally fitted.
    FileEntry => File {
        file: Spanned<String>,
        #[serde(default)]
        fit_size_m: Option<Spanned<f64>>,
    }
);

/// A mesh entry of one kind, as serde reads it from `{ <kind> = <entry> }`.
#[derive(Deserialize)]
#[serde(rename_all = "lowercase")]
enum MeshKind {
    Quad(QuadEntry),
    Box(BoxEntry),
    Icosphere(IcosphereEntry),
    File(FileEntry),
}

/// One `[[mesh]]` entry, typed: its geometry, where it goes and its material.
pub(super) struct MeshEntry {
    pub name: Option<String>,
    pub shape: Shape,
    pub placement: Placement,
    pub albedo: Spanned<f64>,
}

/// The geometry of a mesh entry, in its own frame.
pub(super) enum Shape {
    Quad {
        size: Spanned<Vec<f64>>,
    },
    Box {
        size: Spanned<Vec<f64>>,
    },
    Icosphere {
        radius: Spanned<f64>,
        subdivisions: Option<Spanned<u32>>,
    },
    File {
        file: Spanned<String>,
        fit_size_m: Option<Spanned<f64>>,
    },
}

/// Scale, rotation and translation of a mesh entry (applied in this order).
pub(super) struct Placement {
    pub scale: Option<Spanned<f64>>,
    pub rotate_deg: Option<Spanned<[f64; 3]>>,
    pub rotate_axis: Option<Spanned<[f64; 3]>>,
    pub rotate_angle_deg: Option<Spanned<f64>>,
    pub translate_m: Option<Spanned<[f64; 3]>>,
}

/// A mesh entry's kind, or why it has none: what [`MeshHead`] says.
pub(super) enum Kind {
    /// `primitive = ...`, or `file = ...`: the name of the [`MeshKind`] variant.
    Tag(&'static str),
    /// Both `primitive` and `file`: the span of `file`.
    Both(Range<usize>),
    /// Neither key.
    Neither,
}

impl MeshHead {
    /// The entry's kind, from its `primitive` and `file` keys.
    pub fn kind(&self) -> Kind {
        match (&self.primitive, &self.file) {
            (Some(_), Some(f)) => Kind::Both(f.span()),
            (None, None) => Kind::Neither,
            (Some(p), None) => Kind::Tag(p.get_ref().as_str()),
            (None, Some(_)) => Kind::Tag("file"),
        }
    }
}

/// Deserialize one mesh entry (a table of the parsed document) as the kind `tag` names; the
/// error is the toml crate's, with the span of the key or value at fault.
pub(super) fn mesh_entry(
    entry: &Spanned<DeValue<'_>>,
    tag: &'static str,
) -> Result<MeshEntry, toml::de::Error> {
    let mut table = entry.get_ref().as_table().cloned().unwrap_or_default();
    // The tag of a primitive is the variant's name, as serde's internally tagged enums drop it.
    table.remove("primitive");
    let mut outer = DeTable::new();
    outer.insert(
        Spanned::new(entry.span(), Cow::Borrowed(tag)),
        Spanned::new(entry.span(), DeValue::Table(table)),
    );
    let kind = MeshKind::deserialize(ValueDeserializer::from(Spanned::new(
        entry.span(),
        DeValue::Table(outer),
    )))?;
    Ok(match kind {
        MeshKind::Quad(e) => e.into(),
        MeshKind::Box(e) => e.into(),
        MeshKind::Icosphere(e) => e.into(),
        MeshKind::File(e) => e.into(),
    })
}

/// The key of `table` whose name or value holds byte `offset` of the text, if any.
pub(super) fn key_at(table: &DeValue<'_>, offset: usize) -> Option<String> {
    table.as_table()?.iter().find_map(|(k, v)| {
        let within = |r: Range<usize>| r.start <= offset && offset < r.end.max(r.start + 1);
        (within(k.span()) || within(v.span())).then(|| k.get_ref().to_string())
    })
}
