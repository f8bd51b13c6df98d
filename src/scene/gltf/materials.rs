//! glTF materials into relight's material table: the diffuse reflectance from the PBR
//! factors and the mean colour of the base colour texture, the exitance from the emissive
//! factor, strength and texture.

use std::path::{Path, PathBuf};

use super::buffers::{percent_decode, view_bytes};
use super::{invalid, Buffers, Reader, Unique};
use crate::color::Rgb;
use crate::input_limits::{MAX_EXITANCE, MAX_KD, MAX_MATERIALS, MAX_TEXTURES, MAX_TEXTURE_BYTES};
use crate::scene::materials::{Gloss, Material, MaterialTable};
use crate::scene::{files, mtl, texture, SceneError};

/// A cut-out (`alphaMode` MASK) opaque over at least this share of its area stays an
/// opaque surface; below it, it is a see-through pane passing the rest.
pub const MASK_OPAQUE_SHARE: f64 = 0.5;

/// A material's base colour: the factor tinted by its texture's mean, and the texture's
/// summary (for `alphaMode`).
struct Base {
    colour: Rgb,
    texture: Option<texture::Summary>,
}

/// Where material textures come from: the document's images, the buffers, and the files
/// read (a texture file is added); `count` textures read so far.
struct Textures<'b> {
    doc: &'b gltf::Document,
    buffers: &'b Buffers,
    count: usize,
    files: &'b mut Vec<PathBuf>,
}

impl Reader<'_> {
    /// The material table of the file's materials, and the index in it of every glTF
    /// material; texture files read are added to `files`.
    pub(super) fn materials(
        &mut self,
        doc: &gltf::Document,
        buffers: &Buffers,
        files: &mut Vec<PathBuf>,
    ) -> Result<(MaterialTable, Vec<u32>), SceneError> {
        let textures = &mut Textures {
            doc,
            buffers,
            count: 0,
            files,
        };
        let mut table = MaterialTable::default();
        let mut names = Unique::default();
        let mut out = Vec::new();
        for m in doc.materials() {
            let i = m.index().unwrap_or(0);
            let name = names.take(m.name(), || format!("material{i}"));
            let (kd, gloss, base) = self.reflectance(&m, &name, textures)?;
            let ke = self.emission(&m, &name, textures)?;
            let glass = self.transmittance(&m, &name, &base)?;
            let two_sided =
                m.double_sided() || self.cfg.material.get(&name).is_some_and(|o| o.two_sided);
            let index = table.push(
                Material {
                    name,
                    kd,
                    ke,
                    two_sided,
                    gloss,
                },
                self.shown,
            )?;
            if let Some(t) = glass {
                table.glass.insert(index, t);
            }
            out.push(index);
        }
        Ok((table, out))
    }

    /// The diffuse reflectance of material `m` (named `name`): `(1 − metallic) × base
    /// colour ×` its texture's mean, scaled below 1 (or refused, strict); and its
    /// specular lobe ([`gloss`]); and the texture-tinted base colour.
    fn reflectance(
        &mut self,
        m: &gltf::Material<'_>,
        name: &str,
        textures: &mut Textures<'_>,
    ) -> Result<(Rgb, Option<Gloss>, Base), SceneError> {
        let pbr = m.pbr_metallic_roughness();
        let base = pbr.base_color_factor();
        let metallic = pbr.metallic_factor();
        let roughness = pbr.roughness_factor();
        if !metallic.is_finite() || !roughness.is_finite() {
            return Err(self.err(format!(
                "material '{name}': metallicFactor {metallic} and roughnessFactor \
                 {roughness} must be finite"
            )));
        }
        let metallic = metallic.clamp(0.0, 1.0);
        let texture = match pbr.base_color_texture() {
            Some(info) => self.texture_summary(info.texture(), name, textures)?,
            None => None,
        };
        let factor = Rgb::new(base[0], base[1], base[2]);
        let base = texture.as_ref().map_or(factor, |t| factor * t.mean);
        if base.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(self.err(format!(
                "material '{name}': base colour {base:?} must be finite and ≥ 0"
            )));
        }
        let mut kd = (1.0 - metallic) * base;
        let dielectric = self.dielectric(m, name)?;
        let gloss = gloss(base, metallic, roughness, dielectric);
        if metallic >= 1.0 && base.iter().any(|&b| b > 0.0) {
            self.warnings.push(format!(
                "{}: material '{name}' is fully metallic (metallicFactor 1, the glTF \
                 default): it reflects no diffuse light, and its specular reflection \
                 shows in final images only",
                self.shown.display()
            ));
        }
        if let Some(k) = mtl::clamp_kd(kd) {
            if self.cfg.strict {
                return Err(self.err(format!(
                    "material '{name}': diffuse reflectance {kd:?} must be below 1 per \
                     channel (strict = true; a lenient load would use {k:?})"
                )));
            }
            self.warnings.push(format!(
                "{}: material '{name}': diffuse reflectance reaches 1: scaled to {} {} {} \
                 (at most {MAX_KD})",
                self.shown.display(),
                k[0],
                k[1],
                k[2]
            ));
            kd = k;
        }
        Ok((
            kd,
            gloss,
            Base {
                colour: base,
                texture,
            },
        ))
    }

    /// The glazing transmittance of material `m` (named `name`, of texture-tinted `base`
    /// colour), if the file makes it see-through: `(1 − α) + α · t · Y(base)`, where α is
    /// the opaque share of its area, t the `KHR_materials_transmission` factor (0 without
    /// it) and Y the base colour's luminance (thin-walled glass tints what it transmits by
    /// its base colour). α is:
    /// - under `alphaMode` BLEND, the base colour factor's alpha;
    /// - under MASK, the share of the base colour texture's texels whose alpha (times the
    ///   factor's) reaches `alphaCutoff` ([`texture::Summary::coverage`]; without a
    ///   texture 0 or 1). A cut-out that is opaque over [`MASK_OPAQUE_SHARE`] of its area
    ///   or more (a perforated panel) stays an opaque surface, with a warning: see-through
    ///   materials are not patches, and such a surface reflects more light than it passes;
    /// - 1 under OPAQUE.
    ///
    /// The transmission texture is not read. None for an opaque material (α = 1 and
    /// t = 0).
    fn transmittance(
        &mut self,
        m: &gltf::Material<'_>,
        name: &str,
        base: &Base,
    ) -> Result<Option<f64>, SceneError> {
        let factor = m.pbr_metallic_roughness().base_color_factor()[3];
        let cutoff = m.alpha_cutoff().unwrap_or(0.5);
        let alpha = match m.alpha_mode() {
            gltf::material::AlphaMode::Blend => factor,
            gltf::material::AlphaMode::Mask => {
                let covered = match &base.texture {
                    Some(t) if factor.is_finite() && cutoff.is_finite() => {
                        t.coverage(factor as f64, cutoff as f64) as f32
                    }
                    _ if factor < cutoff => 0.0,
                    _ => 1.0,
                };
                if covered >= MASK_OPAQUE_SHARE as f32 && covered < 1.0 {
                    self.warnings.push(format!(
                        "{}: material '{name}': alphaMode MASK, {:.0} % of its texture                          opaque: kept an opaque surface (set [material.{name}]                          transmittance to make it a see-through pane)",
                        self.shown.display(),
                        100.0 * covered
                    ));
                    1.0
                } else {
                    covered
                }
            }
            _ => 1.0,
        };
        let t = m.transmission().map_or(0.0, |x| x.transmission_factor());
        if !alpha.is_finite() || !t.is_finite() {
            return Err(self.err(format!(
                "material '{name}': alpha {alpha} and transmissionFactor {t} must be finite"
            )));
        }
        let (alpha, t) = (alpha.clamp(0.0, 1.0) as f64, t.clamp(0.0, 1.0) as f64);
        let y = (base.colour.luminance() as f64).clamp(0.0, 1.0);
        let tr = (1.0 - alpha) + alpha * t * y;
        Ok((alpha < 1.0 || t > 0.0).then_some(tr.clamp(0.0, 1.0)))
    }

    /// The exitance of material `m` (named `name`), lm/m²: `π × emissiveFactor ×
    /// strength ×` its emissive texture's mean.
    fn emission(
        &mut self,
        m: &gltf::Material<'_>,
        name: &str,
        textures: &mut Textures<'_>,
    ) -> Result<Rgb, SceneError> {
        let strength = m.emissive_strength().unwrap_or(1.0);
        let ef = m.emissive_factor();
        let mut ke = std::f32::consts::PI * Rgb(ef) * strength;
        if ke.iter().any(|&x| x > 0.0) {
            ke = self.tinted(ke, m.emissive_texture(), name, textures)?;
        }
        if ke
            .iter()
            .any(|x| !x.is_finite() || *x < 0.0 || *x > MAX_EXITANCE)
        {
            return Err(self.err(format!(
                "material '{name}': emission (π × emissiveFactor × strength) {ke:?} lm/m² \
                 must be in [0, {MAX_EXITANCE}]"
            )));
        }
        Ok(ke)
    }

    /// `c` times the mean colour of the texture `info` of material `material`, when it
    /// has one that can be read.
    fn tinted(
        &mut self,
        c: Rgb,
        info: Option<gltf::texture::Info<'_>>,
        material: &str,
        textures: &mut Textures<'_>,
    ) -> Result<Rgb, SceneError> {
        let Some(info) = info else {
            return Ok(c);
        };
        Ok(
            match self.texture_summary(info.texture(), material, textures)? {
                Some(t) => c * t.mean,
                None => c,
            },
        )
    }

    /// The mean linear colour and the alpha spread of a texture's image, or None (with a
    /// warning) when it cannot be read and the load is lenient.
    fn texture_summary(
        &mut self,
        tex: gltf::Texture<'_>,
        material: &str,
        textures: &mut Textures<'_>,
    ) -> Result<Option<texture::Summary>, SceneError> {
        textures.count += 1;
        if textures.count > MAX_TEXTURES {
            return Err(self.err(format!("more than {MAX_TEXTURES} textures")));
        }
        let Some(img) = self.texture_image(&tex, material, textures.doc)? else {
            return Ok(None);
        };
        let what = format!("images[{}]", img.index());
        let bytes = match img.source() {
            gltf::image::Source::View { view, .. } if view.length() as u64 > MAX_TEXTURE_BYTES => {
                Err(self.err(format!(
                    "{what}: larger than {}",
                    files::human_bytes(MAX_TEXTURE_BYTES)
                )))
            }
            gltf::image::Source::View { view, .. } => view_bytes(&view, textures.buffers)
                .map(<[u8]>::to_vec)
                .ok_or_else(|| self.err(format!("{what}: its bufferView lies outside its buffer"))),
            gltf::image::Source::Uri { uri, .. } => {
                let plain = !uri.starts_with("data:");
                match percent_decode(uri) {
                    Some(name) if plain && !self.cfg.strict => {
                        match self.sd.resolve_lenient(&name, self.shown, 0, &what)? {
                            Some(_) => {
                                self.uri_bytes(uri, &what, MAX_TEXTURE_BYTES, textures.files)
                            }
                            None => {
                                self.warnings.push(format!(
                                    "{}: texture '{name}' of material '{material}' is not in \
                                     the scene folder: its factor is used alone",
                                    self.shown.display()
                                ));
                                return Ok(None);
                            }
                        }
                    }
                    _ => self.uri_bytes(uri, &what, MAX_TEXTURE_BYTES, textures.files),
                }
            }
        }?;
        match texture::summary(&bytes) {
            Ok(t) => Ok(Some(t)),
            Err(e) if self.cfg.strict => Err(self.err(format!(
                "{what} (material '{material}') cannot be read: {e} (strict = true)"
            ))),
            Err(e) => {
                self.warnings.push(format!(
                    "{}: {what} of material '{material}' cannot be read ({e}): its factor is \
                     used alone",
                    self.shown.display()
                ));
                Ok(None)
            }
        }
    }
}

impl Reader<'_> {
    /// The image a texture reads: its `EXT_texture_webp` image, else its own `source`.
    /// A texture whose only image is KTX2 (`KHR_texture_basisu`) or AVIF
    /// (`EXT_texture_avif`), which relight does not decode, is None with a warning (its
    /// material's factor is used alone), or an error with `strict`.
    fn texture_image<'d>(
        &mut self,
        tex: &gltf::Texture<'d>,
        material: &str,
        doc: &'d gltf::Document,
    ) -> Result<Option<gltf::Image<'d>>, SceneError> {
        let webp = tex
            .extension_value("EXT_texture_webp")
            .and_then(|v| v.get("source"))
            .and_then(serde_json::Value::as_u64)
            .and_then(|i| doc.images().nth(usize::try_from(i).ok()?));
        if let Some(img) = webp.or_else(|| tex.source()) {
            return Ok(Some(img));
        }
        let kind = ["KHR_texture_basisu", "EXT_texture_avif"]
            .into_iter()
            .find(|e| tex.extension_value(e).is_some());
        let why = match kind {
            Some(e) => format!("its only image is {e}, which relight does not decode"),
            None => "it names no image".to_string(),
        };
        if self.cfg.strict {
            return Err(self.err(format!(
                "textures[{}] of material '{material}': {why} (strict = true)",
                tex.index()
            )));
        }
        self.warnings.push(format!(
            "{}: textures[{}] of material '{material}': {why}: its factor is used alone",
            self.shown.display(),
            tex.index()
        ));
        Ok(None)
    }
}

impl MaterialTable {
    /// Adds a material read from a model file (glTF); its index.
    pub(crate) fn push(&mut self, m: Material, shown: &Path) -> Result<u32, SceneError> {
        if self.materials.len() >= MAX_MATERIALS {
            return Err(invalid(
                shown,
                format!("more than {} materials", MAX_MATERIALS),
            ));
        }
        let i = self.materials.len() as u32;
        self.index.insert(m.name.clone(), i);
        self.materials.push(m);
        Ok(i)
    }
}

/// A dielectric's Fresnel reflectance at normal and grazing incidence, per channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Dielectric {
    pub(super) f0: Rgb,
    pub(super) f90: Rgb,
}

impl Default for Dielectric {
    /// Index 1.5, no `KHR_materials_specular`: F0 0.04, F90 1.
    fn default() -> Self {
        Dielectric {
            f0: Rgb::splat(0.04),
            f90: Rgb::splat(1.0),
        }
    }
}

impl Reader<'_> {
    /// Material `m`'s dielectric Fresnel from `KHR_materials_ior` (F0 =
    /// ((ior − 1)/(ior + 1))², ior 0 meaning F0 = 1) and `KHR_materials_specular` (F0 ×
    /// `specularColorFactor`, at most 1, then both F0 and F90 × `specularFactor`), as the
    /// extensions define them. Their textures are not read.
    fn dielectric(&self, m: &gltf::Material<'_>, name: &str) -> Result<Dielectric, SceneError> {
        let ior = m.ior().unwrap_or(1.5);
        let f0 = if ior == 0.0 {
            1.0
        } else if ior.is_finite() && ior >= 1.0 {
            ((ior - 1.0) / (ior + 1.0)).powi(2)
        } else {
            return Err(self.err(format!(
                "material '{name}': KHR_materials_ior ior {ior} must be at least 1 (or 0)"
            )));
        };
        let Some(spec) = m.specular() else {
            return Ok(Dielectric {
                f0: Rgb::splat(f0),
                f90: Rgb::splat(1.0),
            });
        };
        let (weight, colour) = (spec.specular_factor(), spec.specular_color_factor());
        if !weight.is_finite() || !(0.0..=1.0).contains(&weight) {
            return Err(self.err(format!(
                "material '{name}': KHR_materials_specular specularFactor {weight} must be \
                 in [0, 1]"
            )));
        }
        if colour.iter().any(|c| !c.is_finite() || *c < 0.0) {
            return Err(self.err(format!(
                "material '{name}': KHR_materials_specular specularColorFactor {colour:?} \
                 must be finite and ≥ 0"
            )));
        }
        Ok(Dielectric {
            f0: Rgb(colour.map(|c| (f0 * c).min(1.0) * weight)),
            f90: Rgb::splat(weight),
        })
    }
}

/// glTF's specular lobe for a material of (texture-tinted) `base` colour, `metallic` and
/// perceptual `roughness` factors over a `dielectric` Fresnel: `F0 = dielectric F0 ×
/// (1 − metallic) + base × metallic`, `F90` alike with 1 for the metal, GGX
/// `α = roughness²` (at least [`Gloss::MIN_ALPHA`]). None for a fully rough dielectric
/// (roughness 1, metallic 0), which relight keeps Lambertian, and for a dielectric that
/// reflects nothing specularly (`specularFactor` 0). The `metallicRoughnessTexture` is
/// not read: the factors set the lobe.
pub(super) fn gloss(
    base: Rgb,
    metallic: f32,
    roughness: f32,
    dielectric: Dielectric,
) -> Option<Gloss> {
    let (metallic, roughness) = (metallic.clamp(0.0, 1.0), roughness.clamp(0.0, 1.0));
    let dull = dielectric.f90.iter().all(|&c| c <= 0.0);
    if metallic <= 0.0 && (roughness >= 1.0 || dull) {
        return None;
    }
    let clamp = |c: Rgb| Rgb(c.0.map(|x| x.clamp(0.0, 1.0)));
    Some(Gloss {
        f0: clamp(dielectric.f0 * (1.0 - metallic) + metallic * base),
        f90: clamp(dielectric.f90 * (1.0 - metallic) + Rgb::splat(metallic)),
        alpha: (roughness * roughness).max(Gloss::MIN_ALPHA),
    })
}
