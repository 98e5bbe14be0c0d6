/* unfold.unfold in C, included by planar_bones_kernel.c: the look for turned-over triangles after every frame,
 * and where it finds some, the membrane steps that open them (unfold.py explains both). The same steps in the
 * same order as the numpy, so the same result bit for bit: a Jacobi step does not depend on the order of the
 * vertices, and each sum over a vertex's neighbours runs in the numpy's order. The first look is at the triangles
 * at the `start` vertices the caller names (every triangle where it names none); after that only the triangles at
 * a vertex of the region are looked at again, which gives the numpy's count, since nothing else moved. So a call
 * costs what the folds and the vertices it starts from cost, not the mesh: the positions are read into the work
 * space only where the steps reach, and the work space is kept between calls (its marks are stamps that a later
 * call never reuses), so nothing is allocated, cleared or scanned at the mesh's size. */

/* (b - a) x (c - a) . normal, written out in the numpy's order (unfold._dots) */
static inline double unfold_dot_at(const double *a, const double *b, const double *c, const double *normal) {
    double u0 = b[0] - a[0], u1 = b[1] - a[1], u2 = b[2] - a[2];
    double v0 = c[0] - a[0], v1 = c[1] - a[1], v2 = c[2] - a[2];
    double dot = (u1 * v2 - u2 * v1) * normal[0];
    dot += (u2 * v0 - u0 * v2) * normal[1];
    dot += (u0 * v1 - u1 * v0) * normal[2];
    return dot;
}

/* the dot at a triangle of float positions, its corners taken to double */
static inline double unfold_dot_f32(const float *p, const int32_t *tri, const double *normal) {
    double corner[3][3];
    for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) corner[j][k] = p[3 * (int64_t)tri[j] + k];
    return unfold_dot_at(corner[0], corner[1], corner[2], normal);
}

static inline int unfold_turned(const double *p, const int32_t *tri, const double *normal) {
    return unfold_dot_at(p + 3 * (int64_t)tri[0], p + 3 * (int64_t)tri[1], p + 3 * (int64_t)tri[2], normal) < 0.0;
}

static inline int unfold_turned_f32(const float *p, const int32_t *tri, const double *normal) {
    return unfold_dot_f32(p, tri, normal) < 0.0;
}

/* turned over, or within margin x n.n of it, at float positions (the least share's test, unfold._least_share) */
static inline int unfold_nearly_turned_f32(const float *p, const int32_t *tri, const double *normal, double margin) {
    double rest = normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2];
    return unfold_dot_f32(p, tri, normal) < margin * rest;
}

/* The work space of pbk_unfold on a mesh of n vertices and k triangles, zeroed once by the caller and kept:
 * the stamp counter, then per vertex its region, loaded and moved stamps, per triangle its seen stamp, the
 * positions in double, the next step's and those before the last step (the momentum's), the region's list and
 * the bad triangles. */
typedef struct {
    int64_t *counter, *region, *loaded, *marked, *seen;
    double *p, *next, *last;
    int32_t *list, *bad;
} UnfoldWork;

PBK_EXPORT int64_t pbk_unfold_work_bytes(int64_t n, int64_t k) {
    return (int64_t)sizeof(int64_t) * (1 + 3 * n + k) + (int64_t)sizeof(double) * 9 * n + (int64_t)sizeof(int32_t) * (n + k);
}

static UnfoldWork unfold_work(void *work, int64_t n, int64_t k) {
    UnfoldWork w;
    w.counter = (int64_t *)work;
    w.region = w.counter + 1, w.loaded = w.region + n, w.marked = w.loaded + n, w.seen = w.marked + n;
    w.p = (double *)(w.seen + k), w.next = w.p + 3 * n, w.last = w.next + 3 * n;
    w.list = (int32_t *)(w.last + 3 * n), w.bad = w.list + n;
    return w;
}

/* vertex v's position into the double copy, once per call */
static inline void unfold_load(const UnfoldWork *w, int64_t call, const float *positions, int32_t v) {
    if (w->loaded[v] == call) return;
    w->loaded[v] = call;
    for (int c = 0; c < 3; ++c) w->p[3 * (int64_t)v + c] = positions[3 * (int64_t)v + c];
}

static int unfold_ascending(const void *a, const void *b) {
    int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
    return (x > y) - (x < y);
}

/* positions (n x 3 float32) in place. The first look is at the triangles at the n_start vertices `start` (at
 * every triangle when n_start < 0): the caller vouches that no other triangle is turned over. work: the mesh's
 * work space (pbk_unfold_work_bytes). momentum: each step from Nesterov's look-ahead point x + k / (k + 3)
 * (x - x_last), k the steps since the region last grew (unfold.unfold). moved (n) receives the vertices it may have moved, ascending, and result[0]
 * their count, result[1] the steps made, result[2] the triangles left turned over (where the steps ended with no
 * fewer than they found, none moved and that many are left); share[0] the share of the membrane's change
 * kept. Returns 0. */
PBK_EXPORT int pbk_unfold(int64_t n, int64_t k, const double *rest, const int32_t *triangles,
                          const double *rest_normals, const int32_t *neighbour_start, const int32_t *neighbours,
                          const double *weights, const int32_t *corner_start, const int32_t *corner_triangles, float *positions,
                          int64_t n_start, const int32_t *start, void *work, int32_t max_steps, double step,
                          int32_t check_every, int32_t stall_checks, int32_t bisections, double margin,
                          int32_t momentum, int32_t *moved, int64_t *result, double *share) {
    result[0] = result[1] = result[2] = 0;
    share[0] = 1.0;
    UnfoldWork w = unfold_work(work, n, k);
    int64_t *region = w.region, *seen = w.seen;
    double *p = w.p, *next = w.next, *last = w.last;
    int32_t *list = w.list, *bad = w.bad;
    const int64_t call = ++*w.counter;
    int64_t n_bad = 0;
    if (n_start < 0) {
        for (int64_t t = 0; t < k; ++t)
            if (unfold_turned_f32(positions, triangles + 3 * t, rest_normals + 3 * t)) bad[n_bad++] = (int32_t)t;
    } else {
        const int64_t looked = ++*w.counter;
        for (int64_t s = 0; s < n_start; ++s)
            for (int32_t e = corner_start[start[s]]; e < corner_start[start[s] + 1]; ++e) {
                int32_t t = corner_triangles[e];
                if (seen[t] == looked) continue;
                seen[t] = looked;
                if (unfold_turned_f32(positions, triangles + 3 * (int64_t)t, rest_normals + 3 * (int64_t)t))
                    bad[n_bad++] = t;
            }
    }
    const int64_t found = n_bad;
    int64_t count = n_bad;
    if (count == 0) return 0;
    int64_t rings = 1, steps = 0, best = count, stall = 0, n_moved = 0, since = 0, before = -1;
    while (count && steps < max_steps) {
        /* the region: the bad triangles' corners, then `rings` rings of neighbours (a stamp marks membership;
         * `before` the last batch's, so that a vertex new to the region is seen: the momentum starts again) */
        const int64_t stamp = ++*w.counter;
        int64_t size = 0, grew = 0;
        for (int64_t b = 0; b < n_bad; ++b)
            for (int c = 0; c < 3; ++c) {
                int32_t v = triangles[3 * (int64_t)bad[b] + c];
                if (region[v] != stamp) grew |= region[v] != before, region[v] = stamp, list[size++] = v;
            }
        for (int64_t r = 0, from = 0; r < rings; ++r) {
            int64_t to = size;
            for (int64_t m = from; m < to; ++m)
                for (int32_t e = neighbour_start[list[m]]; e < neighbour_start[list[m] + 1]; ++e) {
                    int32_t v = neighbours[e];
                    if (region[v] != stamp) grew |= region[v] != before, region[v] = stamp, list[size++] = v;
                }
            from = to;
        }
        before = stamp;
        int64_t kept = 0; /* the numpy drops vertices without neighbours (in no triangle: none of a bad one's) */
        for (int64_t m = 0; m < size; ++m) {
            int32_t v = list[m];
            if (neighbour_start[v + 1] == neighbour_start[v]) continue;
            list[kept++] = v;
            if (w.marked[v] != call) w.marked[v] = call, moved[n_moved++] = v;
            unfold_load(&w, call, positions, v); /* the vertex and every neighbour a step reads */
            for (int32_t e = neighbour_start[v]; e < neighbour_start[v + 1]; ++e)
                unfold_load(&w, call, positions, neighbours[e]);
        }
        size = kept;
        if (grew) since = 0;
        int64_t batch = max_steps - steps < check_every ? max_steps - steps : check_every;
        for (int64_t s = 0; s < batch; ++s, ++steps) {
            if (momentum) { /* the step is taken from y = x + beta (x - x_last), in p; x_last <- x */
                const double beta = (double)since / (double)(since + 3);
                for (int64_t m = 0; m < size; ++m)
                    for (int c = 0; c < 3; ++c) {
                        const int64_t at = 3 * (int64_t)list[m] + c;
                        const double x = p[at];
                        if (since) p[at] = x + beta * (x - last[at]);
                        last[at] = x;
                    }
                ++since;
            }
            for (int64_t m = 0; m < size; ++m) {
                int32_t v = list[m];
                int32_t first = neighbour_start[v], last = neighbour_start[v + 1];
                double total[3];
                const int64_t head = 3 * (int64_t)neighbours[first];
                for (int c = 0; c < 3; ++c) total[c] = weights[first] * (p[head + c] - rest[head + c]);
                for (int32_t e = first + 1; e < last; ++e)
                    for (int c = 0; c < 3; ++c)
                        total[c] += weights[e] * (p[3 * (int64_t)neighbours[e] + c] - rest[3 * (int64_t)neighbours[e] + c]);
                for (int c = 0; c < 3; ++c) {
                    double own = p[3 * (int64_t)v + c] - rest[3 * (int64_t)v + c];
                    next[3 * m + c] = p[3 * (int64_t)v + c] + step * (total[c] - own);
                }
            }
            for (int64_t m = 0; m < size; ++m)
                for (int c = 0; c < 3; ++c) p[3 * (int64_t)list[m] + c] = next[3 * m + c];
        }
        /* look again at the triangles of the region's vertices (their corners are the region's or neighbours of
         * it: loaded) */
        n_bad = 0;
        for (int64_t m = 0; m < size; ++m)
            for (int32_t e = corner_start[list[m]]; e < corner_start[list[m] + 1]; ++e) {
                int32_t t = corner_triangles[e];
                if (seen[t] == stamp) continue;
                seen[t] = stamp;
                if (unfold_turned(p, triangles + 3 * (int64_t)t, rest_normals + 3 * (int64_t)t)) bad[n_bad++] = t;
            }
        count = n_bad;
        if (count < best) {
            best = count, stall = 0;
        } else if (++stall >= stall_checks) {
            ++rings, stall = 0;
        }
    }
    if (count >= found) { /* the budget ended with no fewer turned over: the positions stay as they came */
        result[1] = steps, result[2] = found;
        return 0;
    }
    qsort(moved, (size_t)n_moved, sizeof *moved, unfold_ascending);
    double high = 1.0;
    if (count == 0) { /* the least share of the change that leaves no triangle at a moved vertex (nearly) turned */
        const int64_t stamp = ++*w.counter;
        int64_t n_at = 0;
        for (int64_t m = 0; m < n_moved; ++m)
            for (int32_t e = corner_start[moved[m]]; e < corner_start[moved[m] + 1]; ++e)
                if (seen[corner_triangles[e]] != stamp)
                    seen[corner_triangles[e]] = stamp, bad[n_at++] = corner_triangles[e];
        for (int64_t m = 0; m < n_moved; ++m) /* the deformed positions, before the change */
            for (int c = 0; c < 3; ++c) next[3 * m + c] = positions[3 * (int64_t)moved[m] + c];
        double low = 0.0;
        for (int32_t i = 0; i < bisections; ++i) {
            double half = 0.5 * (low + high);
            for (int64_t m = 0; m < n_moved; ++m)
                for (int c = 0; c < 3; ++c) {
                    double before = next[3 * m + c];
                    int64_t at = 3 * (int64_t)moved[m] + c;
                    positions[at] = (float)(before + half * (p[at] - before));
                }
            int turned = 0;
            for (int64_t b = 0; b < n_at && !turned; ++b)
                turned = unfold_nearly_turned_f32(positions, triangles + 3 * (int64_t)bad[b],
                                                  rest_normals + 3 * (int64_t)bad[b], margin);
            if (turned)
                low = half;
            else
                high = half;
        }
        share[0] = high;
    }
    for (int64_t m = 0; m < n_moved; ++m)
        for (int c = 0; c < 3; ++c) {
            int64_t at = 3 * (int64_t)moved[m] + c;
            positions[at] = high == 1.0 ? (float)p[at] : (float)(next[3 * m + c] + high * (p[at] - next[3 * m + c]));
        }
    result[0] = n_moved, result[1] = steps, result[2] = count;
    return 0;
}

/* The look at the triangles of the classes that have a group flagged off its rest (unfold.Look): class c's
 * triangles are rows class_start[c] .. class_start[c + 1] of corners and rest_normals (sorted by class, so read in
 * one stream), its groups class_groups[3c .. 3c + 2] (the distinct groups of their corners, the last repeated).
 * The corners of each turned-over one go to found (3 per triangle, room for all); returns how many triangles. */
PBK_EXPORT int64_t pbk_turned_at(int64_t n_classes, const uint8_t *off_rest, const int32_t *class_groups,
                                 const int32_t *class_start, const int32_t *corners, const double *rest_normals,
                                 const float *positions, int32_t *found) {
    int64_t count = 0;
    for (int64_t c = 0; c < n_classes; ++c) {
        if (!(off_rest[class_groups[3 * c]] | off_rest[class_groups[3 * c + 1]] | off_rest[class_groups[3 * c + 2]]))
            continue;
        for (int64_t t = class_start[c]; t < class_start[c + 1]; ++t)
            if (unfold_turned_f32(positions, corners + 3 * t, rest_normals + 3 * t)) {
                for (int j = 0; j < 3; ++j) found[3 * count + j] = corners[3 * t + j];
                ++count;
            }
    }
    return count;
}
