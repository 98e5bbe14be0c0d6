/* The kernel's loops over vertices, included by planar_bones_kernel.c once per coefficient type REAL (float or
 * double; the output has the same type) and instruction set: the 4-wide loaders LOAD (of REALs) and LOAD64 (of
 * doubles), the lane sums LANES, the function attribute TARGET and the function names SUM, RANGE and LIST. A vertex sums its pairs
 * lane by lane in double and adds the lanes up once at the end (SUM); RANGE runs over a range of vertices, a
 * vertex whose pairs' triangles all are at rest taking its result at rest, and LIST over listed vertices. */

/* out[u]: its rest value plus, for each pair whose triangle moved, its coefficients times its rows' motion. A
 * pair whose triangle is at rest has rows [-shift, 0, 0, 0] and an apex pair's in-plane part equal to the one at
 * rest: it adds -w shift, which its weight takes back, so its coefficients are not even read. base[u][3] is the
 * vertex's exact weight sum less its rounded coefficients' weights; with the moved pairs' weights added back it
 * is the weight that carries the shift (the exact sum when every pair moved, as in a rigid motion). */
TARGET static inline __attribute__((always_inline)) void SUM(int64_t u, const double *base, const int32_t *plain_start,
                                                             const int32_t *plain_key, const REAL *plain_coef,
                                                             const int32_t *apex_start, const int32_t *apex_key,
                                                             const REAL *apex_coef, const REAL *scale,
                                                             const Tables *tables, Quad shift, REAL *out) {
    Quad x = {0.0, 0.0, 0.0, 0.0}, y = x, z = x;
    double weight = 0.0;
    const unsigned char *moved = tables->moved_triangle;
    for (int32_t p = plain_start[u]; p < plain_start[u + 1]; ++p) {
        int64_t key = plain_key[p]; /* triangle x 4 + region */
        if (!moved[key >> 2]) continue;
        const Quad *rows = tables->plain + 3 * key;
        Quad c = LOAD(plain_coef + 4 * (int64_t)p);
        weight += c[0];
        x += c * rows[0];
        y += c * rows[1];
        z += c * rows[2];
    }
    if (apex_start) {
        for (int32_t p = apex_start[u]; p < apex_start[u + 1]; ++p) {
            int64_t key = apex_key[p]; /* triangle x 3 + corner */
            if (!moved[key / 3]) continue;
            const Quad *rows = tables->apex + 6 * key;
            const REAL *coef = apex_coef + 4 * (int64_t)p;
            double r = apex_ratio(coef[2], coef[3], tables->gram[key], scale[p]);
            double r_rest = tables->apex_rest[p];
            Quad c = LOAD(coef) * (Quad){1.0, 1.0, r, r}; /* [w, h w, a r, b r] on [dVj, dn, b'j, b'(j-1)] */
            Quad c_rest = {-coef[2] * r_rest, -coef[3] * r_rest, 0.0, 0.0}; /* less a r b_j + b r b(j-1) at rest */
            weight += c[0];
            x += c * rows[0] + c_rest * rows[3];
            y += c * rows[1] + c_rest * rows[4];
            z += c * rows[2] + c_rest * rows[5];
        }
    }
    Quad rest = LOAD64(base + 4 * u); /* x, y, z and the weight correction */
    Quad sum = rest + (rest[3] + weight) * shift + LANES(x, y, z);
    out[3 * u] = (REAL)sum[0];
    out[3 * u + 1] = (REAL)sum[1];
    out[3 * u + 2] = (REAL)sum[2];
}

TARGET static void RANGE(int64_t v0, int64_t v1, const double *base, const int32_t *plain_start,
                         const int32_t *plain_key, const void *plain_coefficients, const int32_t *apex_start,
                         const int32_t *apex_key, const void *apex_coefficients, const void *apex_scales,
                         const void *rest_output, const uint64_t *vertex_mask, const Tables *table, void *output) {
    const REAL *rest_out = rest_output;
    const Tables tables = *table;
    REAL *out = output;
    const Quad shift = LOAD64(tables.shift);
    for (int64_t u = v0; u < v1; ++u) {
        if (!((vertex_mask[2 * u] & tables.moved[0]) | (vertex_mask[2 * u + 1] & tables.moved[1]))) {
            /* every pair's triangle is at rest: the result at rest */
            out[3 * u] = rest_out[3 * u];
            out[3 * u + 1] = rest_out[3 * u + 1];
            out[3 * u + 2] = rest_out[3 * u + 2];
            continue;
        }
        SUM(u, base, plain_start, plain_key, plain_coefficients, apex_start, apex_key, apex_coefficients, apex_scales,
            &tables, shift, output);
    }
}

/* The vertices listed in `work` [w0, w1), each of which has a pair whose triangle moved (the grouped entry
 * point lists only those). */
TARGET static void LIST(int64_t w0, int64_t w1, const int32_t *work, const double *base, const int32_t *plain_start,
                        const int32_t *plain_key, const void *plain_coefficients, const int32_t *apex_start,
                        const int32_t *apex_key, const void *apex_coefficients, const void *apex_scales,
                        const Tables *table, void *output) {
    const Tables tables = *table;
    const Quad shift = LOAD64(tables.shift);
    for (int64_t w = w0; w < w1; ++w)
        SUM(work[w], base, plain_start, plain_key, plain_coefficients, apex_start, apex_key, apex_coefficients,
            apex_scales, &tables, shift, output);
}
