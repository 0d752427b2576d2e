// Per-corner data of the solver kernels. A kernel importing this declares
// `corners: array<u32>` (CORNER_STRIDE per corner) and `shapes:
// array<vec4<real>>` (4 rows per table entry) and `x: array<real>`.

#import layout

struct CornerRef {
    b: array<vec3<real>, 4>,
    // the corner's weight in F
    w: real,
    // a surface corner's unit reference normal (rows 1-3's w); zero otherwise
    n: vec3<real>,
}

fn corner_ref(c: u32) -> CornerRef {
    let t = 4u * corners_get(CORNER_STRIDE * c + 4u);
    let r0 = shapes[t];
    let r1 = shapes[t + 1u];
    let r2 = shapes[t + 2u];
    let r3 = shapes[t + 3u];
    return CornerRef(array<vec3<real>, 4>(r0.xyz, r1.xyz, r2.xyz, r3.xyz), r0.w, vec3<real>(r1.w, r2.w, r3.w));
}

fn corner_point(v: u32) -> vec3<real> {
    return vec3<real>(x_get(3u * v), x_get(3u * v + 1u), x_get(3u * v + 2u));
}

fn corner_points(c: u32) -> array<vec3<real>, 4> {
    let at = CORNER_STRIDE * c;
    return array<vec3<real>, 4>(
        corner_point(corners_get(at)),
        corner_point(corners_get(at + 1u)),
        corner_point(corners_get(at + 2u)),
        corner_point(corners_get(at + 3u)),
    );
}
