//! A z-buffer triangle rasteriser: flat-coloured triangles into an RGB frame, with a shadow
//! mask filled by triangles that lie on already drawn surfaces.

/// A vertex in pixel coordinates (x right, y down; pixel centres at +0.5) with the inverse of
/// its depth along the viewing direction, which is linear in screen space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenVertex {
    /// Horizontal pixel coordinate.
    pub x: f32,
    /// Vertical pixel coordinate (down).
    pub y: f32,
    /// 1 / depth (1/m); larger is closer.
    pub inv_depth: f32,
}

/// An RGB picture with its depth buffer and shadow mask.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
    inv_depth: Vec<f32>,
    /// 1 where a shadow falls, else 0 (bytes, so that eight are tested at once).
    shadow: Vec<u8>,
    /// The segment id of what is drawn at each pixel (empty unless
    /// [`Frame::with_segmentation`]): 0 where nothing was drawn.
    ids: Vec<u8>,
    /// The segment id [`Frame::fill_triangle`] writes.
    segment: u8,
}

/// Relative depth difference under which a shadow triangle counts as lying on the surface
/// drawn at that pixel.
const SHADOW_DEPTH_TOLERANCE: f32 = 2e-3;

impl Frame {
    /// A black frame, everything infinitely far.
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            rgb: vec![0; n * 3],
            inv_depth: vec![0.0; n],
            shadow: vec![0; n],
            ids: Vec::new(),
            segment: 0,
        }
    }

    /// The frame with a segment id per pixel (see [`Frame::set_segment`]), or without one.
    /// Colours and depths are the same bits either way.
    pub fn with_segmentation(mut self, on: bool) -> Self {
        let n = self.width as usize * self.height as usize;
        self.ids = if on { vec![0; n] } else { Vec::new() };
        self
    }

    /// The segment id the triangles drawn next write where they are drawn.
    pub fn set_segment(&mut self, id: u8) {
        self.segment = id;
    }

    /// Row-major segment ids, `height * width` (empty without segmentation).
    pub fn segments(&self) -> &[u8] {
        &self.ids
    }

    /// Row-major inverse depths (1/m along the viewing direction), `height * width`; 0 where
    /// nothing was drawn.
    pub fn inv_depths(&self) -> &[f32] {
        &self.inv_depth
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Row-major RGB bytes, `height * width * 3`.
    pub fn rgb(&self) -> &[u8] {
        &self.rgb
    }

    /// The RGB bytes, to change in place.
    pub fn rgb_mut(&mut self) -> &mut [u8] {
        &mut self.rgb
    }

    /// The colour of pixel (`x`, `y`).
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let i = (y as usize * self.width as usize + x as usize) * 3;
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// Depth at pixel (`x`, `y`) (m); infinite where nothing was drawn.
    pub fn depth(&self, x: u32, y: u32) -> f32 {
        1.0 / self.inv_depth[y as usize * self.width as usize + x as usize]
    }

    /// Fills the picture with `background` (one colour per row), clears depth and shadows.
    pub fn clear(&mut self, background: &[[u8; 3]]) {
        let w = self.width as usize;
        for (row, color) in self.rgb.chunks_exact_mut(w * 3).zip(background) {
            for px in row.chunks_exact_mut(3) {
                px.copy_from_slice(color);
            }
        }
        self.inv_depth.fill(0.0);
        self.shadow.fill(0);
        self.ids.fill(0);
    }

    /// Makes this frame a copy of `other` (of the same size), reusing its buffers.
    pub fn copy_from(&mut self, other: &Frame) {
        debug_assert_eq!((self.width, self.height), (other.width, other.height));
        self.rgb.copy_from_slice(&other.rgb);
        self.inv_depth.copy_from_slice(&other.inv_depth);
        self.shadow.copy_from_slice(&other.shadow);
        self.ids.copy_from_slice(&other.ids);
    }

    /// Draws a triangle in `color` where it is closer than what is there.
    /// With segmentation, the pixels drawn take the current segment id too.
    pub fn fill_triangle(&mut self, v: &[ScreenVertex; 3], color: [u8; 3]) {
        let width = self.width as usize;
        let (rgb, depth) = (&mut self.rgb, &mut self.inv_depth);
        if self.ids.is_empty() {
            rasterize(self.width, self.height, v, |x, y, z| {
                let i = y * width + x;
                if z > depth[i] {
                    depth[i] = z;
                    rgb[i * 3..i * 3 + 3].copy_from_slice(&color);
                }
            });
        } else {
            let (ids, segment) = (&mut self.ids, self.segment);
            rasterize(self.width, self.height, v, |x, y, z| {
                let i = y * width + x;
                if z > depth[i] {
                    depth[i] = z;
                    rgb[i * 3..i * 3 + 3].copy_from_slice(&color);
                    ids[i] = segment;
                }
            });
        }
    }

    /// Marks as shadowed the pixels where this triangle lies on the drawn surface (within a
    /// small depth tolerance): a shadow projected onto a plane shows only where that plane is
    /// visible.
    pub fn mark_shadow(&mut self, v: &[ScreenVertex; 3]) {
        let width = self.width as usize;
        let (shadow, depth) = (&mut self.shadow, &self.inv_depth);
        rasterize(self.width, self.height, v, |x, y, z| {
            let i = y * width + x;
            if (z - depth[i]).abs() <= SHADOW_DEPTH_TOLERANCE * depth[i] {
                shadow[i] = 1;
            }
        });
    }

    /// Marks as shadowed the pixels of the convex polygon `polygon` (its corners in pixel
    /// coordinates, in order, either winding) where it lies on the drawn surface, as
    /// [`Frame::mark_shadow`] does for a triangle; `depth` is the polygon's plane, `[a, b, c]`
    /// for an inverse depth of `a x + b y + c` at a pixel centre (x, y). `spans` is a scratch
    /// buffer.
    pub fn mark_shadow_polygon(
        &mut self,
        polygon: &[[f32; 2]],
        depth: [f32; 3],
        spans: &mut Vec<Span>,
    ) {
        let n = polygon.len();
        if n < 3 {
            return;
        }
        let (mut twice_area, mut min_y, mut max_y) = (0.0f32, f32::INFINITY, f32::NEG_INFINITY);
        for (i, p) in polygon.iter().enumerate() {
            let q = polygon[(i + 1) % n];
            twice_area += p[0] * q[1] - q[0] * p[1];
            min_y = min_y.min(p[1]);
            max_y = max_y.max(p[1]);
        }
        // Degenerate, or NaN (which fails every comparison).
        if twice_area.is_nan()
            || twice_area.abs() <= 1e-12
            || !(min_y.is_finite() && max_y.is_finite())
        {
            return;
        }
        // Rows whose pixel centres the polygon can cover, clipped to the picture.
        let (top, bottom) = (min_y - 0.5, max_y - 0.5);
        if bottom < 0.0 || top > (self.height - 1) as f32 {
            return;
        }
        let (y0, y1) = (
            ceil_to_index(top),
            floor_index(bottom).min(self.height as usize - 1),
        );
        if y0 > y1 {
            return;
        }
        spans.clear();
        spans.resize(y1 - y0 + 1, Span::OPEN);
        // Each edge bounds the rows it crosses on one side: a pixel centre is inside when it
        // lies on the same side of every edge as the polygon's area (as in `rasterize`).
        let sign = twice_area.signum();
        for (i, p) in polygon.iter().enumerate() {
            let q = polygon[(i + 1) % n];
            let dy = q[1] - p[1];
            if dy == 0.0 || !dy.is_finite() {
                continue;
            }
            let left = sign * dy < 0.0;
            let slope = (q[0] - p[0]) / dy;
            let (lo, hi) = (p[1].min(q[1]) - 0.5, p[1].max(q[1]) - 0.5);
            if hi < index_to_f32(y0) || lo > index_to_f32(y1) {
                continue;
            }
            let (r0, r1) = (ceil_to_index(lo).max(y0), floor_index(hi).min(y1));
            for r in r0..=r1 {
                let x = p[0] + (index_to_f32(r) + 0.5 - p[1]) * slope;
                let span = &mut spans[r - y0];
                if left {
                    span.left = span.left.max(x);
                } else {
                    span.right = span.right.min(x);
                }
            }
        }
        let width = self.width as usize;
        let [a, b, c] = depth;
        for (k, span) in spans.iter().enumerate() {
            // A row either edge chain missed (rounding at a corner) is left alone.
            if !(span.left.is_finite() && span.right.is_finite()) {
                continue;
            }
            let (lo, hi) = (span.left - 0.5, span.right - 0.5);
            if hi < 0.0 || lo > index_to_f32(width - 1) || lo > hi {
                continue;
            }
            let (x0, x1) = (ceil_to_index(lo), floor_index(hi).min(width - 1));
            let y = y0 + k;
            let row = b * (index_to_f32(y) + 0.5) + c;
            for x in x0..=x1 {
                let z = a * (index_to_f32(x) + 0.5) + row;
                let i = y * width + x;
                let d = self.inv_depth[i];
                if (z - d).abs() <= SHADOW_DEPTH_TOLERANCE * d {
                    self.shadow[i] = 1;
                }
            }
        }
    }

    /// Darkens shadowed pixels to `factor` of their colour (0 to 256 = 1.0).
    pub fn apply_shadows(&mut self, factor: u16) {
        let darken = |px: &mut [u8]| {
            for c in px {
                *c = ((u16::from(*c) * factor) >> 8) as u8;
            }
        };
        // Most of a picture is not in shadow: eight pixels are passed over at once.
        let mut words = self.shadow.chunks_exact(8);
        for (k, word) in (&mut words).enumerate() {
            if word.iter().fold(0u8, |m, &s| m | s) == 0 {
                continue;
            }
            for (j, &s) in word.iter().enumerate() {
                if s != 0 {
                    let i = (k * 8 + j) * 3;
                    darken(&mut self.rgb[i..i + 3]);
                }
            }
        }
        let tail = self.shadow.len() - words.remainder().len();
        for (j, &s) in words.remainder().iter().enumerate() {
            if s != 0 {
                let i = (tail + j) * 3;
                darken(&mut self.rgb[i..i + 3]);
            }
        }
    }
}

/// The part of a pixel row inside a polygon, between two horizontal positions (pixels).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    /// The left edge (no pixel centre to its left is inside).
    pub left: f32,
    /// The right edge.
    pub right: f32,
}

impl Span {
    /// A row not yet bounded on either side.
    pub const OPEN: Span = Span {
        left: f32::NEG_INFINITY,
        right: f32::INFINITY,
    };
}

/// `v.ceil().max(0.0)` as an index, without the call to `ceilf` (targets without SSE4.1 have
/// no instruction for it): the same value for every `v` that is not NaN, saturating at
/// `u32::MAX` (pictures are far smaller). For the last pixel the callers use [`floor_index`].
fn ceil_to_index(v: f32) -> usize {
    if v <= 0.0 {
        return 0;
    }
    let t = v as u32;
    (if (t as f32) < v {
        t.saturating_add(1)
    } else {
        t
    }) as usize
}

/// `v.floor().max(0.0)` as an index (NaN gives 0), saturating at `u32::MAX`. Through `u32`
/// because converting an `f32` to a `usize` (an unsigned 64-bit integer) takes about a dozen
/// x86-64 instructions, and to a `u32` a few; every caller then clamps to the picture.
fn floor_index(v: f32) -> usize {
    v as u32 as usize
}

/// A pixel index as an `f32` (exact: pictures are at most [`crate::MAX_SIZE`] across), through
/// `u32` for the same reason as [`floor_index`].
fn index_to_f32(i: usize) -> f32 {
    i as u32 as f32
}

/// Calls `f(x, y, inv_depth)` for every pixel whose centre lies inside the triangle (either
/// winding), clipped to the `width` x `height` picture.
fn rasterize(width: u32, height: u32, v: &[ScreenVertex; 3], mut f: impl FnMut(usize, usize, f32)) {
    if width == 0 || height == 0 {
        return;
    }
    let [a, b, c] = v;
    let edge = |p: &ScreenVertex, q: &ScreenVertex, x: f32, y: f32| {
        (q.x - p.x) * (y - p.y) - (q.y - p.y) * (x - p.x)
    };
    let area = edge(a, b, c.x, c.y);
    // Degenerate, or NaN (which fails every comparison).
    if area.is_nan() || area.abs() <= 1e-12 {
        return;
    }
    // Bounding box of the pixel centres the triangle can cover, clipped to the picture.
    let min_x = a.x.min(b.x).min(c.x) - 0.5;
    let max_x = a.x.max(b.x).max(c.x) - 0.5;
    let min_y = a.y.min(b.y).min(c.y) - 0.5;
    let max_y = a.y.max(b.y).max(c.y) - 0.5;
    if max_x < 0.0 || max_y < 0.0 || min_x > (width - 1) as f32 || min_y > (height - 1) as f32 {
        return;
    }
    let x0 = ceil_to_index(min_x);
    let x1 = floor_index(max_x).min(width as usize - 1);
    let y0 = ceil_to_index(min_y);
    let y1 = floor_index(max_y).min(height as usize - 1);
    let inv_area = 1.0 / area;
    // Barycentric weights of a, b, c are the edges opposite them over the area; both step
    // linearly along a row.
    let (da, db, dc) = (
        -(c.y - b.y) * inv_area,
        -(a.y - c.y) * inv_area,
        -(b.y - a.y) * inv_area,
    );
    for y in y0..=y1 {
        let py = index_to_f32(y) + 0.5;
        let px = index_to_f32(x0) + 0.5;
        let mut wa = edge(b, c, px, py) * inv_area;
        let mut wb = edge(c, a, px, py) * inv_area;
        let mut wc = edge(a, b, px, py) * inv_area;
        // Each weight steps by a constant, so it only grows or only shrinks along the row (a
        // rounded sum never steps back): the pixels inside form one run. Step up to it, draw
        // it, and leave the row where it ends.
        let mut x = x0;
        while x <= x1 && !(wa >= 0.0 && wb >= 0.0 && wc >= 0.0) {
            wa += da;
            wb += db;
            wc += dc;
            x += 1;
        }
        while x <= x1 && wa >= 0.0 && wb >= 0.0 && wc >= 0.0 {
            f(x, y, wa * a.inv_depth + wb * b.inv_depth + wc * c.inv_depth);
            wa += da;
            wb += db;
            wc += dc;
            x += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32, y: f32, depth: f32) -> ScreenVertex {
        ScreenVertex {
            x,
            y,
            inv_depth: 1.0 / depth,
        }
    }

    fn covered(frame: &Frame, color: [u8; 3]) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        for y in 0..frame.height() {
            for x in 0..frame.width() {
                if frame.pixel(x, y) == color {
                    out.push((x, y));
                }
            }
        }
        out
    }

    #[test]
    fn a_right_triangle_covers_the_pixels_below_its_diagonal() {
        let mut frame = Frame::new(8, 8);
        frame.clear(&[[0, 0, 0]; 8]);
        // Corners at pixel edges: pixel (x, y) is inside when its centre is, x + y <= 7.
        frame.fill_triangle(
            &[v(0.0, 0.0, 1.0), v(8.0, 0.0, 1.0), v(0.0, 8.0, 1.0)],
            [255, 0, 0],
        );
        let got = covered(&frame, [255, 0, 0]);
        let expected: Vec<(u32, u32)> = (0..8u32)
            .flat_map(|y| (0..8u32).map(move |x| (x, y)))
            .filter(|&(x, y)| x + y < 8)
            .collect();
        assert_eq!(got, expected);
        // Winding does not matter.
        let mut other = Frame::new(8, 8);
        other.clear(&[[0, 0, 0]; 8]);
        other.fill_triangle(
            &[v(0.0, 0.0, 1.0), v(0.0, 8.0, 1.0), v(8.0, 0.0, 1.0)],
            [255, 0, 0],
        );
        assert_eq!(other, frame);
    }

    #[test]
    fn the_closer_triangle_wins_whatever_the_order() {
        let near = [v(0.0, 0.0, 1.0), v(10.0, 0.0, 1.0), v(0.0, 10.0, 1.0)];
        let far = [v(0.0, 0.0, 2.0), v(10.0, 0.0, 2.0), v(0.0, 10.0, 2.0)];
        for order in [[near, far], [far, near]] {
            let mut frame = Frame::new(10, 10);
            frame.clear(&[[0, 0, 0]; 10]);
            frame.fill_triangle(
                &order[0],
                if order[0] == near {
                    [1, 1, 1]
                } else {
                    [2, 2, 2]
                },
            );
            frame.fill_triangle(
                &order[1],
                if order[1] == near {
                    [1, 1, 1]
                } else {
                    [2, 2, 2]
                },
            );
            assert_eq!(frame.pixel(1, 1), [1, 1, 1]);
            assert!((frame.depth(1, 1) - 1.0).abs() < 1e-6);
            assert!(frame.depth(9, 9).is_infinite());
        }
    }

    #[test]
    fn off_screen_and_degenerate_triangles_draw_nothing() {
        let mut frame = Frame::new(4, 4);
        frame.clear(&[[0, 0, 0]; 4]);
        let before = frame.clone();
        frame.fill_triangle(
            &[
                v(-10.0, -10.0, 1.0),
                v(-5.0, -10.0, 1.0),
                v(-10.0, -5.0, 1.0),
            ],
            [9, 9, 9],
        );
        frame.fill_triangle(
            &[v(0.0, 0.0, 1.0), v(4.0, 4.0, 1.0), v(2.0, 2.0, 1.0)],
            [9, 9, 9],
        );
        frame.fill_triangle(
            &[v(f32::NAN, 0.0, 1.0), v(4.0, 0.0, 1.0), v(0.0, 4.0, 1.0)],
            [9, 9, 9],
        );
        assert_eq!(frame, before);
        // Huge triangles are clipped to the picture.
        frame.fill_triangle(
            &[v(-1e6, -1e6, 1.0), v(1e6, -1e6, 1.0), v(0.0, 1e6, 1.0)],
            [9, 9, 9],
        );
        assert_eq!(covered(&frame, [9, 9, 9]).len(), 16);
    }

    #[test]
    fn ceil_to_index_is_ceil_clamped_at_zero() {
        for v in [
            -1e30f32,
            -3.5,
            -1.0,
            -0.5,
            -0.0,
            0.0,
            1e-7,
            0.5,
            1.0,
            1.0001,
            2.5,
            83.0,
            83.49,
            1e6,
            3e9,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ] {
            let expected = (v.ceil().max(0.0) as usize).min(u32::MAX as usize);
            assert_eq!(ceil_to_index(v), expected, "{v}");
            let expected = (v.floor().max(0.0) as usize).min(u32::MAX as usize);
            assert_eq!(floor_index(v), expected, "{v}");
        }
    }

    #[test]
    fn a_shadow_polygon_marks_what_its_triangles_mark() {
        let surface = || {
            let mut frame = Frame::new(40, 30);
            frame.clear(&[[200, 200, 200]; 30]);
            // A surface at depth 2 over most of the picture, and a nearer one over a corner.
            frame.fill_triangle(
                &[v(-5.0, -5.0, 2.0), v(90.0, -5.0, 2.0), v(-5.0, 90.0, 2.0)],
                [200, 200, 200],
            );
            frame.fill_triangle(
                &[v(25.0, 0.0, 1.0), v(40.0, 0.0, 1.0), v(40.0, 12.0, 1.0)],
                [90, 90, 90],
            );
            frame
        };
        // A convex heptagon reaching off the picture, both windings.
        let corners: Vec<[f32; 2]> = (0..7)
            .map(|k| {
                let a = 0.3 + k as f32 * std::f32::consts::TAU / 7.0;
                [21.37 + 19.3 * a.cos(), 13.11 + 17.9 * a.sin()]
            })
            .collect();
        let mut fan = surface();
        for k in 1..corners.len() - 1 {
            let t = [corners[0], corners[k], corners[k + 1]].map(|[x, y]| v(x, y, 2.0));
            fan.mark_shadow(&t);
        }
        fan.apply_shadows(128);
        for polygon in [corners.clone(), corners.iter().rev().copied().collect()] {
            let mut frame = surface();
            frame.mark_shadow_polygon(&polygon, [0.0, 0.0, 0.5], &mut Vec::new());
            frame.apply_shadows(128);
            assert_eq!(frame, fan);
        }
        assert!(covered(&fan, [100, 100, 100]).len() > 300);
        // Degenerate and non-finite polygons mark nothing.
        let mut frame = surface();
        let before = frame.clone();
        for polygon in [
            vec![[1.0, 1.0], [5.0, 5.0], [9.0, 9.0]],
            vec![[1.0, 1.0], [f32::NAN, 5.0], [9.0, 1.0]],
            vec![[1.0, 1.0], [f32::INFINITY, 5.0], [9.0, 1.0]],
            vec![[1.0, 1.0], [9.0, 1.0]],
        ] {
            frame.mark_shadow_polygon(&polygon, [0.0, 0.0, 0.5], &mut Vec::new());
        }
        frame.apply_shadows(128);
        assert_eq!(frame, before);
    }

    #[test]
    fn shadows_mark_only_the_surface_they_lie_on() {
        let mut frame = Frame::new(10, 10);
        frame.clear(&[[200, 200, 200]; 10]);
        frame.fill_triangle(
            &[v(0.0, 0.0, 2.0), v(10.0, 0.0, 2.0), v(0.0, 10.0, 2.0)],
            [200, 200, 200],
        );
        // A shadow at the same depth darkens; one behind the surface does not.
        frame.mark_shadow(&[v(0.0, 0.0, 2.0), v(4.0, 0.0, 2.0), v(0.0, 4.0, 2.0)]);
        frame.mark_shadow(&[v(5.0, 0.0, 3.0), v(9.0, 0.0, 3.0), v(5.0, 4.0, 3.0)]);
        frame.apply_shadows(128);
        assert_eq!(frame.pixel(0, 0), [100, 100, 100]);
        assert_eq!(frame.pixel(6, 0), [200, 200, 200]);
    }
}
