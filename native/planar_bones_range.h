/* The kernel's loops over vertices, included by planar_bones_kernel.c once per coefficient type REAL (float or
 * double; the output has the same type) and instruction set: the 4-wide loaders LOAD (of REALs) and LOAD64 (of
 * doubles), the function attribute TARGET and the function names SUM, RANGE and LIST. A vertex sums its pairs
 * lane by lane in double and adds the lanes up once at the end (SUM); RANGE runs over a range of vertices, a
 * vertex whose pairs' triangles all are at rest taking its result at rest, and LIST over listed vertices. */

/* out[u]: its rest value plus each pair's coefficients times its rows' motion. `ratio` holds the apex factors
 * of the pairs from `first` on, computed together beforehand, or is NULL: each is then computed as it comes. */
TARGET static inline __attribute__((always_inline)) void SUM(int64_t u, const double *base, const int32_t *plain_start,
                                                             const int32_t *plain_key, const REAL *plain_coef,
                                                             const int32_t *apex_start, const int32_t *apex_key,
                                                             const REAL *apex_coef, const REAL *scale,
                                                             const double *ratio, int32_t first,
                                                             const Tables *tables, Quad shift, REAL *out) {
    Quad x = {0.0, 0.0, 0.0, 0.0}, y = x, z = x;
    for (int32_t p = plain_start[u]; p < plain_start[u + 1]; ++p) {
        const Quad *rows = tables->plain + 3 * (int64_t)plain_key[p];
        Quad c = LOAD(plain_coef + 4 * (int64_t)p);
        x += c * rows[0];
        y += c * rows[1];
        z += c * rows[2];
    }
    if (apex_start) {
        for (int32_t p = apex_start[u]; p < apex_start[u + 1]; ++p) {
            int64_t key = apex_key[p];
            const Quad *rows = tables->apex + 3 * key;
            const REAL *coef = apex_coef + 4 * (int64_t)p;
            double r = ratio ? ratio[p - first] : apex_ratio(coef[2], coef[3], tables->gram[key], scale[p]);
            Quad c = LOAD(coef) * (Quad){1.0, 1.0, r, r};
            x += c * rows[0];
            y += c * rows[1];
            z += c * rows[2];
        }
    }
    Quad rest = LOAD64(base + 4 * u); /* x, y, z and the weight sum */
    Quad sum = rest + rest[3] * shift + lane_sums(x, y, z);
    out[3 * u] = (REAL)sum[0];
    out[3 * u + 1] = (REAL)sum[1];
    out[3 * u + 2] = (REAL)sum[2];
}

TARGET static void RANGE(int64_t v0, int64_t v1, const double *base, const int32_t *plain_start,
                         const int32_t *plain_key, const void *plain_coefficients, const int32_t *apex_start,
                         const int32_t *apex_key, const void *apex_coefficients, const void *apex_scales,
                         const void *rest_output, const uint64_t *vertex_mask, const Tables *table, void *output) {
    const REAL *plain_coef = plain_coefficients, *apex_coef = apex_coefficients, *scale = apex_scales;
    const REAL *rest_out = rest_output;
    const Tables tables = *table;
    REAL *out = output;
    const Quad shift = LOAD64(tables.shift);
    double ratio[APEX_BLOCK];
    unsigned char moved[VERTEX_BLOCK];
    for (int64_t v = v0; v < v1;) {
        /* vertices [v, end), at most a block, whose apex pairs [first, last) fit in one block */
        int64_t end = v + 1;
        int32_t first = 0, last = 0;
        if (apex_start) {
            first = apex_start[v];
            while (end < v1 && end - v < VERTEX_BLOCK && apex_start[end + 1] - first <= APEX_BLOCK) ++end;
            last = apex_start[end];
        } else {
            end = v1 - v < VERTEX_BLOCK ? v1 : v + VERTEX_BLOCK;
        }
        /* which of them have a pair whose triangle moved (only their pairs are read) */
        for (int64_t u = v; u < end; ++u)
            moved[u - v] = ((vertex_mask[2 * u] & tables.moved[0]) | (vertex_mask[2 * u + 1] & tables.moved[1])) != 0;
        int blocked = last - first <= APEX_BLOCK; /* else one vertex with more than a block: one by one */
        if (blocked && apex_start)
            for (int64_t u = v; u < end; ++u) {
                if (!moved[u - v]) continue;
                for (int32_t p = apex_start[u]; p < apex_start[u + 1]; ++p) {
                    const REAL *c = apex_coef + 4 * (int64_t)p;
                    ratio[p - first] = apex_ratio(c[2], c[3], tables.gram[apex_key[p]], scale[p]);
                }
            }
        for (int64_t u = v; u < end; ++u) {
            if (!moved[u - v]) { /* every pair's triangle is at rest: the result at rest */
                out[3 * u] = rest_out[3 * u];
                out[3 * u + 1] = rest_out[3 * u + 1];
                out[3 * u + 2] = rest_out[3 * u + 2];
                continue;
            }
            SUM(u, base, plain_start, plain_key, plain_coef, apex_start, apex_key, apex_coef, scale,
                blocked && apex_start ? ratio : NULL, first, &tables, shift, out);
        }
        v = end;
    }
}

/* The vertices listed in `work` [w0, w1), each of which has a pair whose triangle moved (the grouped entry
 * point lists only those): no stillness test, each apex factor computed as it comes. */
TARGET static void LIST(int64_t w0, int64_t w1, const int32_t *work, const double *base, const int32_t *plain_start,
                        const int32_t *plain_key, const void *plain_coefficients, const int32_t *apex_start,
                        const int32_t *apex_key, const void *apex_coefficients, const void *apex_scales,
                        const Tables *table, void *output) {
    const Tables tables = *table;
    const Quad shift = LOAD64(tables.shift);
    for (int64_t w = w0; w < w1; ++w)
        SUM(work[w], base, plain_start, plain_key, plain_coefficients, apex_start, apex_key, apex_coefficients,
            apex_scales, NULL, 0, &tables, shift, output);
}
