// Seed 004's smooth subdivision (Sec. 3.1, eqs. 2-3) evaluated at its limit: the uniform
// bicubic B-spline of a texture of control points (src/view3d/subdivision.rs is the CPU
// reference, with the same arithmetic in the same order; tests/view3d_subdivision.rs checks
// they agree). 16 texel loads (textureLoad: no filtering, no storage buffers, so WebGL2 runs
// it); one ring of ghost control points outside the texture, each the linear extrapolation
// of the two inside it. The module this is prepended to declares the texture of control
// points as `height_tex` (a global rather than a function parameter, so no backend,
// WebGL2's GLSL ES included, has to pass a texture handle into a function).

// Weights of the control points i - 1 .. i + 2 at i + t, t in [0, 1].
fn bspline_basis(t: f32) -> vec4<f32> {
    let s = 1.0 - t;
    let t2 = t * t;
    let t3 = t2 * t;
    return vec4<f32>(
        s * s * s / 6.0,
        (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
        (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
        t3 / 6.0,
    );
}

fn bspline_row(y: i32, ix: i32, size: vec2<i32>, wx: vec4<f32>) -> f32 {
    let last = size.x - 1;
    let row = clamp(y, 0, size.y - 1);
    var r = vec4<f32>(
        textureLoad(height_tex, vec2<i32>(clamp(ix - 1, 0, last), row), 0).r,
        textureLoad(height_tex, vec2<i32>(clamp(ix, 0, last), row), 0).r,
        textureLoad(height_tex, vec2<i32>(clamp(ix + 1, 0, last), row), 0).r,
        textureLoad(height_tex, vec2<i32>(clamp(ix + 2, 0, last), row), 0).r,
    );
    if (ix - 1 < 0) {
        r.x = 2.0 * r.y - r.z;
    }
    if (ix + 2 > last) {
        r.w = 2.0 * r.z - r.y;
    }
    return r.x * wx.x + r.y * wx.y + r.z * wx.z + r.w * wx.w;
}

// The limit surface at p (texels; clamped to the grid).
fn bspline_height(p: vec2<f32>) -> f32 {
    let size = max(vec2<i32>(textureDimensions(height_tex, 0)), vec2<i32>(1));
    let top = vec2<f32>(size - vec2<i32>(1));
    let q = clamp(p, vec2<f32>(0.0), top);
    let base = clamp(floor(q), vec2<f32>(0.0), max(top - vec2<f32>(1.0), vec2<f32>(0.0)));
    let t = min(q - base, vec2<f32>(1.0));
    let wx = bspline_basis(t.x);
    let wy = bspline_basis(t.y);
    let i = vec2<i32>(base);
    var c = vec4<f32>(
        bspline_row(i.y - 1, i.x, size, wx),
        bspline_row(i.y, i.x, size, wx),
        bspline_row(i.y + 1, i.x, size, wx),
        bspline_row(i.y + 2, i.x, size, wx),
    );
    if (i.y - 1 < 0) {
        c.x = 2.0 * c.y - c.z;
    }
    if (i.y + 2 > size.y - 1) {
        c.w = 2.0 * c.z - c.y;
    }
    return c.x * wy.x + c.y * wy.y + c.z * wy.z + c.w * wy.w;
}
