//! The server's cache of views: per (scene, camera, size), the view buffer and, made on
//! first use, per-light-group images. An LRU bounded by the bytes its entries really hold,
//! with one build per view however many requests ask for it at once.

use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Mutex, OnceLock};

use super::{AppState, Ready};
use crate::model::{Cancel, Lighting, QueryError};
use crate::render::final_gather;
use crate::render::pipeline::{self, RenderOptions};
use crate::render::{Camera, GroupImages, ViewBuffer};

type ViewKey = (String, [u32; 12]);

/// One cached view: its buffer and, made on first use when they are smaller than the
/// buffer, per-light-group images; and, once asked for, its `final` images.
pub struct View {
    pub buffer: ViewBuffer,
    groups: OnceLock<Option<GroupImages>>,
    /// The `final` quality's per-group images, once built (one build at a time).
    finals: Mutex<Option<Arc<GroupImages>>>,
    /// The `final` image of the daylight under the last sky asked for (its key), once
    /// built: a new sky state builds it again, as a new camera does.
    daylight: Mutex<Option<(String, Arc<GroupImages>)>>,
    /// The `final` image of the last lighting state asked for that the groups' images
    /// cannot sum to (an emission vector, luminaires placed per request), by its key
    /// ([`state_key`]): a new such state traces it again.
    state: Mutex<Option<(u64, Arc<GroupImages>)>>,
}

impl View {
    /// Bytes this entry holds now: the buffer, plus its group images once made.
    fn bytes(&self) -> usize {
        self.buffer.bytes()
            + self
                .groups
                .get()
                .and_then(|g| g.as_ref())
                .map_or(0, GroupImages::bytes)
            + lock(&self.finals).as_ref().map_or(0, |f| f.bytes())
            + lock(&self.daylight).as_ref().map_or(0, |(_, f)| f.bytes())
            + lock(&self.state).as_ref().map_or(0, |(_, f)| f.bytes())
    }

    /// Whether the `final` images are built.
    pub fn has_finals(&self) -> bool {
        lock(&self.finals).is_some()
    }

    /// The `final` images for `ready`'s light groups with `settings`, built now when not
    /// cached (holding this view's lock, so concurrent requests wait for one build).
    /// `Err(Cancelled)` when `cancel` is raised during the build; the next request starts
    /// again.
    pub fn final_images(
        &self,
        ready: &Ready,
        cam: &Camera,
        settings: &final_gather::FinalSettings,
        cancel: &Cancel,
    ) -> Result<Arc<GroupImages>, QueryError> {
        let mut slot = lock(&self.finals);
        if let Some(f) = slot.as_ref() {
            return Ok(f.clone());
        }
        let built = crate::render::pipeline::final_images(
            &ready.model,
            ready.shading(),
            ready.patch_locator(),
            cam,
            settings,
            cancel,
        )?;
        let built = Arc::new(built);
        *slot = Some(built.clone());
        Ok(built)
    }

    /// The `final` image of the daylight under `sky` with `settings`, built now unless the
    /// last one built was for the same sky (one build at a time, as [`Self::final_images`]).
    pub fn final_daylight(
        &self,
        ready: &Ready,
        cam: &Camera,
        sky: &crate::model::sky_state::SkyState,
        settings: &final_gather::FinalSettings,
        cancel: &Cancel,
    ) -> Result<Arc<GroupImages>, QueryError> {
        let key = format!("{sky:?}");
        let mut slot = lock(&self.daylight);
        if let Some((k, f)) = slot.as_ref() {
            if *k == key {
                return Ok(f.clone());
            }
        }
        *slot = None;
        let built = Arc::new(crate::render::pipeline::final_daylight_image(
            &ready.model,
            ready.shading(),
            ready.patch_locator(),
            cam,
            sky,
            settings,
            cancel,
        )?);
        *slot = Some((key, built.clone()));
        Ok(built)
    }

    /// The `final` image of `lighting`, a state that is not of light groups alone
    /// ([`pipeline::final_state_image`]), traced now unless it was the last such state
    /// asked for (one build at a time, as [`Self::final_images`]).
    pub fn final_state(
        &self,
        ready: &Ready,
        cam: &Camera,
        lighting: &Lighting,
        settings: &final_gather::FinalSettings,
        cancel: &Cancel,
    ) -> Result<Arc<GroupImages>, QueryError> {
        let key = state_key(lighting);
        let mut slot = lock(&self.state);
        if let Some((k, f)) = slot.as_ref() {
            if *k == key {
                return Ok(f.clone());
            }
        }
        *slot = None;
        let built = Arc::new(pipeline::final_state_image(
            &ready.model,
            ready.shading(),
            ready.patch_locator(),
            cam,
            lighting,
            settings,
            cancel,
        )?);
        *slot = Some((key, built.clone()));
        Ok(built)
    }

    /// Whether the `final` image of the state with key `key` is cached.
    fn has_state(&self, key: u64) -> bool {
        lock(&self.state).as_ref().is_some_and(|(k, _)| *k == key)
    }

    /// Whether group images for `groups` light groups would still have to be made.
    fn group_images_pending(&self, groups: usize) -> bool {
        self.groups.get().is_none() && GroupImages::worthwhile(&self.buffer, groups)
    }

    /// Per-group images for `ready`'s light groups, or None when a gather reads less.
    pub fn group_images(&self, ready: &Ready) -> Option<&GroupImages> {
        self.groups
            .get_or_init(|| {
                let t = &ready.model.baked.transfer;
                if !GroupImages::worthwhile(&self.buffer, t.group_count()) {
                    return None;
                }
                Some(GroupImages::radiance(&self.buffer, ready.shading(), t))
            })
            .as_ref()
    }
}

/// A cache slot: filled once by the first request for its key; concurrent requests for
/// the same key wait for that build instead of building their own.
#[derive(Default)]
struct Slot {
    view: OnceLock<Arc<View>>,
    building: Mutex<()>,
}

/// A least-recently-used cache of views, bounded by the bytes its entries really hold
/// (buffers and group images, measured by allocated capacity).
pub struct ViewCache {
    map: HashMap<ViewKey, Arc<Slot>>,
    order: VecDeque<ViewKey>,
    max_bytes: usize,
}

impl ViewCache {
    pub fn new(max_bytes: u64) -> ViewCache {
        ViewCache {
            map: HashMap::new(),
            order: VecDeque::new(),
            max_bytes: max_bytes.min(usize::MAX as u64) as usize,
        }
    }

    /// The slot for `k`, made empty if new; marks it most recently used.
    fn slot(&mut self, k: &ViewKey) -> Arc<Slot> {
        self.order.retain(|x| x != k);
        self.order.push_back(k.clone());
        self.map.entry(k.clone()).or_default().clone()
    }

    /// The finished view for `k`, if cached.
    fn peek(&self, k: &ViewKey) -> Option<Arc<View>> {
        self.map.get(k).and_then(|s| s.view.get().cloned())
    }

    /// Bytes held by finished entries.
    pub fn bytes(&self) -> usize {
        self.map
            .values()
            .filter_map(|s| s.view.get())
            .map(|v| v.bytes())
            .sum()
    }

    /// Evicts least recently used finished entries until the cache fits its bound.
    /// Entries still being built are left alone (their builders hold a reservation).
    pub fn trim(&mut self) {
        let mut total = self.bytes();
        let mut k = 0;
        while total > self.max_bytes && k < self.order.len() {
            let key = self.order[k].clone();
            let done = self
                .map
                .get(&key)
                .and_then(|s| s.view.get().map(|v| v.bytes()));
            match done {
                Some(b) => {
                    self.map.remove(&key);
                    self.order.remove(k);
                    total -= b;
                }
                None => k += 1,
            }
        }
    }

    /// Drops a slot whose build failed, so that the next request tries again.
    fn forget_empty(&mut self, k: &ViewKey) {
        if self.map.get(k).is_some_and(|s| s.view.get().is_none()) {
            self.map.remove(k);
            self.order.retain(|x| x != k);
        }
    }

    /// Drops every view of scene `id` (its scene was replaced or deleted).
    pub fn forget_scene(&mut self, id: &str) {
        self.map.retain(|k, _| k.0 != id);
        self.order.retain(|k| k.0 != id);
    }

    /// Finished views cached.
    pub fn len(&self) -> usize {
        self.map.values().filter(|s| s.view.get().is_some()).count()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

fn view_key(ready: &Ready, cam: &Camera) -> ViewKey {
    (ready.model.baked.scene.id.clone(), cam.key())
}

/// The view buffer for this scene and camera, from the cache or built now. Concurrent
/// requests for the same view wait for one build. The caller has reserved the build's
/// memory (see [`render_estimate`]).
pub fn view_for(state: &AppState, ready: &Ready, cam: &Camera) -> Arc<View> {
    let key = view_key(ready, cam);
    let slot = lock(&state.views).slot(&key);
    if let Some(v) = slot.view.get() {
        return v.clone();
    }
    let _building = lock(&slot.building);
    if let Some(v) = slot.view.get() {
        return v.clone();
    }
    let built = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        Arc::new(View {
            buffer: ViewBuffer::build(&ready.model.baked.mesh, ready.shading(), cam),
            groups: OnceLock::new(),
            finals: Mutex::new(None),
            daylight: Mutex::new(None),
            state: Mutex::new(None),
        })
    }));
    match built {
        Ok(v) => {
            let v = slot.view.get_or_init(|| v).clone();
            lock(&state.views).trim();
            v
        }
        Err(p) => {
            lock(&state.views).forget_empty(&key);
            std::panic::resume_unwind(p)
        }
    }
}

/// A key of a lighting state: equal states have equal keys (a hash of every number of the
/// state, luminaires included).
pub fn state_key(lighting: &Lighting) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    match lighting {
        Lighting::Groups(w) => {
            0u8.hash(&mut h);
            w.iter()
                .flat_map(|c| c.0)
                .for_each(|v| v.to_bits().hash(&mut h));
        }
        Lighting::Emission(e) => {
            1u8.hash(&mut h);
            e.iter().for_each(|v| v.to_bits().hash(&mut h));
        }
        // Debug prints every number in full (the shortest text that reads back the same).
        Lighting::Placed(p) => (2u8, format!("{p:?}")).hash(&mut h),
    }
    h.finish()
}

/// What the cache holds of the view `o` renders under `lighting` ([`pipeline::Made`]),
/// for the render's memory estimate ([`pipeline::estimate_bytes`]).
pub fn made(
    state: &AppState,
    ready: &Ready,
    o: &RenderOptions,
    lighting: &Lighting,
) -> pipeline::Made {
    let groups = ready.model.baked.transfer.group_count();
    let cached = lock(&state.views).peek(&view_key(ready, &o.camera));
    let state_image = match lighting {
        Lighting::Groups(_) => None,
        _ => Some(
            cached
                .as_ref()
                .is_some_and(|v| v.has_state(state_key(lighting))),
        ),
    };
    pipeline::Made {
        view: cached.as_ref().map(|v| {
            if v.group_images_pending(groups) {
                GroupImages::estimate_bytes(&v.buffer, groups)
            } else {
                0
            }
        }),
        finals: cached.as_ref().is_some_and(|v| v.has_finals()),
        state_image,
        gather_points: ready.gather_points(),
        patch_locator: ready.patch_locator_pending_bytes(),
    }
}

/// Peak bytes a render of `o` (under a sky when `sky`) may allocate beyond what the cache
/// holds.
pub fn render_estimate(
    state: &AppState,
    ready: &Ready,
    o: &RenderOptions,
    lighting: &Lighting,
    sky: bool,
) -> u64 {
    let made = made(state, ready, o, lighting);
    pipeline::estimate_bytes(&ready.model, o, sky, &made)
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Trims the view cache to its bound (after an entry grew by its group images).
pub fn trim(state: &AppState) {
    lock(&state.views).trim();
}
