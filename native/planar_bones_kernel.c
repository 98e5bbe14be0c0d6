/* Fused Planar Bones / SoFFD evaluation (eq. 1, 8, 12, 13-14): one pass that writes each vertex once.
 *
 * Plain C with no Python C-API, loaded through ctypes, so one shared library serves every Python. The
 * layout is built (and every index in it checked) by addon/deform/fused.py, whose notes explain it.
 *
 * out[v] = base[v] + sum over v's pairs of (the pair's image now - its image at rest). An image is linear
 * in the rows of its triangle's deformation basis [V0, V1, V2, n, b0, b1, b2] (eq. 3, 7, 10), so a pair
 * adds 4 coefficients times how far 4 rows (or combinations of rows) moved since rest:
 *   face region, key triangle x 4:       [w, a w, b w, h w] . [dV0, dV1 - dV0, dV2 - dV0, dn]     (eq. 1)
 *   edge j, key triangle x 4 + 1 + j:    [w, x w, y w, h w] . [dVj, dV(j+1) - dVj, dbj, dn]      (eq. 12)
 * (SoFFD mode: every pair as a face pair.) An apex pair (corner j, key triangle x 3 + j) adds
 *   [w, h w, a r, b r] . [dVj, dn, b'j, b'(j-1)] with r = w D / d', d' = |a b'j + b b'(j-1)|  (eq. 13-14)
 * whose in-plane part at rest fused.py has already taken off base.
 *
 * A triangle none of whose corners moved since rest adds exactly nothing (its rows are -shift, which the
 * vertex's weight sum takes back, and its in-plane apex part is the one at rest): a vertex all of whose pairs
 * have such triangles is its result at rest, `rest_out`, copied without reading its pairs. Which triangles a
 * vertex has pairs with is a 128-bit mask per vertex (bit t % 128 for triangle t: exact up to 128 triangles,
 * beyond that a still vertex may be summed as a moving one, which is right too). In speech most triangles
 * (the brows', the cheeks') stay still while the mouth moves.
 *
 * The grouped entry point (pbk_evaluate_groups_*) serves a caller that keeps `out` from one frame to the next:
 * the vertices come in groups with the same triangles, only the groups with a moved triangle are summed (from a
 * list, split among the threads), and a still group is written only when it has just come to rest.
 */
#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define PBK_ABI_VERSION 14
#define PBK_MAX_THREADS 16
#define CHUNKS_PER_THREAD 8 /* chunks of work per thread, claimed in turn */
#define PARALLEL_WORK 150000 /* grouped entry point: below this much work (pairs, an apex pair twice) one thread */

#if defined(_WIN32)
#define PBK_EXPORT __declspec(dllexport)
#else
#define PBK_EXPORT __attribute__((visibility("default")))
#endif

/* On x86-64 with GCC or Clang, an AVX2 + FMA variant of the loop too, chosen at run time by the CPU. */
#if defined(__x86_64__) && defined(__GNUC__)
#define PBK_AVX2 1
#include <cpuid.h>
#include <immintrin.h>
#define AVX2_TARGET __attribute__((target("avx2,fma")))
#else
#define PBK_AVX2 0
#endif

/* Four doubles: one component (x, y or z) of a key's four rows, or a pair's four coefficients. */
typedef double Quad __attribute__((vector_size(32), aligned(32)));
typedef float Quad32 __attribute__((vector_size(16)));

typedef struct {
    double shift[4];    /* the translation every vertex takes times its weight sum (x, y, z, 0) */
    const Quad *plain;  /* per plain key: x, y, z of its 4 rows */
    const Quad *apex;   /* per apex key: x, y, z of dVj, dn, b'j, b'(j-1), then of bj, b(j-1) at rest, 0, 0 */
    const double *gram; /* per apex key: g' = b'j . b'(j-1) */
    const unsigned char *moved_triangle; /* per triangle: 1 when it moved since rest */
    const double *apex_rest;             /* per apex pair: its factor r = w D / d at rest (eq. 13-14) */
    uint64_t moved[2]; /* bit t % 128: triangle t moved since rest */
} Tables;

PBK_EXPORT int pbk_abi_version(void) { return PBK_ABI_VERSION; }

typedef struct {
    double v[7][3]; /* V0, V1, V2, n, b0, b1, b2 */
} Basis;

static void unit(double *v) {
    double norm = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int k = 0; k < 3; ++k) v[k] = norm > 0.0 ? v[k] / norm : 0.0; /* a collapsed triangle: zero */
}

static void cross(const double *a, const double *b, double *out) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* regions.deformation_basis for one triangle of the control points (M, 3). */
static Basis triangle_basis(const double *control, const int32_t *corners) {
    Basis basis;
    double edge[3][3], diagonal[3];
    for (int j = 0; j < 3; ++j) memcpy(basis.v[j], control + 3 * (int64_t)corners[j], sizeof basis.v[j]);
    for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) edge[j][k] = basis.v[(j + 1) % 3][k] - basis.v[j][k];
    for (int k = 0; k < 3; ++k) diagonal[k] = basis.v[2][k] - basis.v[0][k];
    cross(edge[0], diagonal, basis.v[3]); /* eq. 3 */
    unit(basis.v[3]);
    for (int j = 0; j < 3; ++j) {
        cross(edge[j], basis.v[3], basis.v[4 + j]); /* b_j = unit(e_j x n) */
        unit(basis.v[4 + j]);
    }
    return basis;
}

/* Components x, y, z of four rows, as three Quads. */
static void transpose(const double *r0, const double *r1, const double *r2, const double *r3, Quad *out) {
    for (int k = 0; k < 3; ++k) out[k] = (Quad){r0[k], r1[k], r2[k], r3[k]};
}

/* The tables of one frame, from the control points now and at rest and the triangles (T, 3). The rows
 * dVj are taken relative to `shift`, the mean motion of the triangles' first corners, whose share every
 * vertex gets with its exact weight sum: so no rounded coefficient multiplies a translation. */
static void build_tables(int64_t n_triangles, const double *control, const double *control_rest,
                         const double *rest_bases, const int32_t *triangles, Quad *plain, Quad *apex, double *gram, double *shift,
                         unsigned char *moved_triangle, uint64_t *moved_bits) {
    double mean[3] = {0.0, 0.0, 0.0};
    for (int64_t t = 0; t < n_triangles; ++t)
        for (int k = 0; k < 3; ++k) {
            int64_t corner = 3 * (int64_t)triangles[3 * t];
            mean[k] += (control[corner + k] - control_rest[corner + k]) / (double)n_triangles;
        }
    for (int k = 0; k < 3; ++k) shift[k] = mean[k];
    shift[3] = 0.0;
    moved_bits[0] = moved_bits[1] = 0;
    for (int64_t t = 0; t < n_triangles; ++t) {
        unsigned char moved = 0; /* NaN compares unequal: such a triangle is summed as before */
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) {
                int64_t at = 3 * (int64_t)triangles[3 * t + j] + k;
                moved |= control[at] != control_rest[at];
            }
        if (moved) moved_bits[(t / 64) % 2] |= (uint64_t)1 << (t % 64);
        moved_triangle[t] = moved;
        Basis now = triangle_basis(control, triangles + 3 * t);
        Basis rest;
        memcpy(&rest, rest_bases + 21 * t, sizeof rest);
        double d[7][3], along[3][3];
        for (int r = 0; r < 7; ++r)
            for (int k = 0; k < 3; ++k) d[r][k] = now.v[r][k] - rest.v[r][k] - (r < 3 ? mean[k] : 0.0);
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) along[j][k] = d[(j + 1) % 3][k] - d[j][k];
        double diagonal[3] = {d[2][0] - d[0][0], d[2][1] - d[0][1], d[2][2] - d[0][2]};
        transpose(d[0], along[0], diagonal, d[3], plain + 12 * t);
        for (int j = 0; j < 3; ++j) {
            const double *edge_normal = now.v[4 + j], *previous = now.v[4 + (j + 2) % 3];
            const double *rest_normal = rest.v[4 + j], *rest_previous = rest.v[4 + (j + 2) % 3], zero[3] = {0.0};
            int64_t key = 3 * t + j;
            transpose(d[j], along[j], d[4 + j], d[3], plain + 12 * t + 3 * (1 + j));
            transpose(d[j], d[3], edge_normal, previous, apex + 6 * key);
            transpose(rest_normal, rest_previous, zero, zero, apex + 6 * key + 3);
            gram[key] = edge_normal[0] * previous[0] + edge_normal[1] * previous[1] + edge_normal[2] * previous[2];
        }
    }
}

/* r = w D / d' for d' = sqrt(a^2 + b^2 + 2 a b g'), 0 where d' = 0 (eq. 13's limit). Divides and then
 * selects; with -fno-math-errno -fno-trapping-math a loop of these has no branch and vectorises. */
static inline __attribute__((always_inline)) double apex_ratio(double a, double b, double gram, double scale) {
    double squared = a * a + b * b + 2.0 * a * b * gram;
    double d = sqrt(squared > 0.0 ? squared : 0.0);
    double ratio = scale / d;
    return d > 0.0 ? ratio : 0.0;
}

/* (sum of x's lanes, of y's, of z's, 0); one per variant, since Clang passes a 4-double vector to a function
 * compiled without AVX differently than to one with it, and refuses the mix */
#define DEFINE_LANE_SUMS(NAME, ATTRIBUTES)                                                                        \
    static inline __attribute__((always_inline)) ATTRIBUTES Quad NAME(Quad x, Quad y, Quad z) {                 \
        Quad zero = {0.0, 0.0, 0.0, 0.0};                                                                       \
        Quad xy = __builtin_shufflevector(x, y, 0, 4, 2, 6) + __builtin_shufflevector(x, y, 1, 5, 3, 7);         \
        Quad z0 = __builtin_shufflevector(z, zero, 0, 4, 2, 6) + __builtin_shufflevector(z, zero, 1, 5, 3, 7);   \
        return __builtin_shufflevector(xy, z0, 0, 1, 4, 5) + __builtin_shufflevector(xy, z0, 2, 3, 6, 7);        \
    }
DEFINE_LANE_SUMS(lane_sums, )
#if PBK_AVX2
DEFINE_LANE_SUMS(lane_sums_avx2, AVX2_TARGET)
#endif

/* Four coefficients as doubles: portable loaders, and where there is AVX2 one instruction each. */
static inline __attribute__((always_inline)) Quad load_f32(const float *p) {
    Quad32 q;
    memcpy(&q, p, sizeof q);
    return __builtin_convertvector(q, Quad);
}

static inline __attribute__((always_inline)) Quad load_f64(const double *p) {
    Quad q;
    memcpy(&q, p, sizeof q);
    return q;
}

#define REAL float
#define LOAD load_f32
#define LOAD64 load_f64
#define LANES lane_sums
#define RANGE range_f32
#define LIST list_f32
#define SUM sum_f32
#define TARGET
#include "planar_bones_range.h"
#undef REAL
#undef LOAD
#undef LOAD64
#undef LANES
#undef RANGE
#undef LIST
#undef SUM
#undef TARGET

#define REAL double
#define LOAD load_f64
#define LOAD64 load_f64
#define LANES lane_sums
#define RANGE range_f64
#define LIST list_f64
#define SUM sum_f64
#define TARGET
#include "planar_bones_range.h"
#undef REAL
#undef LOAD
#undef LOAD64
#undef LANES
#undef RANGE
#undef LIST
#undef SUM
#undef TARGET

#if PBK_AVX2
static inline __attribute__((always_inline)) AVX2_TARGET Quad load_f32_avx2(const float *p) {
    return (Quad)_mm256_cvtps_pd(_mm_loadu_ps(p));
}

static inline __attribute__((always_inline)) AVX2_TARGET Quad load_f64_avx2(const double *p) {
    return (Quad)_mm256_loadu_pd(p);
}

#define REAL float
#define LOAD load_f32_avx2
#define LOAD64 load_f64_avx2
#define LANES lane_sums_avx2
#define RANGE range_f32_avx2
#define LIST list_f32_avx2
#define SUM sum_f32_avx2
#define TARGET AVX2_TARGET
#include "planar_bones_range.h"
#undef REAL
#undef LOAD
#undef LOAD64
#undef LANES
#undef RANGE
#undef LIST
#undef SUM
#undef TARGET

#define REAL double
#define LOAD load_f64_avx2
#define LOAD64 load_f64_avx2
#define LANES lane_sums_avx2
#define RANGE range_f64_avx2
#define LIST list_f64_avx2
#define SUM sum_f64_avx2
#define TARGET AVX2_TARGET
#include "planar_bones_range.h"
#undef REAL
#undef LOAD
#undef LOAD64
#undef LANES
#undef RANGE
#undef LIST
#undef SUM
#undef TARGET
#endif

typedef void Range(int64_t, int64_t, const double *, const int32_t *, const int32_t *, const void *,
                   const int32_t *, const int32_t *, const void *, const void *, const void *, const uint64_t *,
                   const Tables *, void *);

typedef void List(int64_t, int64_t, const int32_t *, const double *, const int32_t *, const int32_t *,
                  const void *, const int32_t *, const int32_t *, const void *, const void *, const Tables *, void *);

#if PBK_AVX2
static int has_avx2(void) {
    static int avx2 = -1;
    if (avx2 < 0) {
        /* CPUID and XGETBV rather than __builtin_cpu_supports, whose run-time support MinGW lacks: AVX2 and FMA,
         * and an OS that saves the YMM registers */
        unsigned a, b, c, d, xcr0 = 0, xcr0_high;
        int avx = __get_cpuid(1, &a, &b, &c, &d) && (c & bit_FMA) && (c & bit_AVX) && (c & bit_OSXSAVE);
        if (avx) __asm__("xgetbv" : "=a"(xcr0), "=d"(xcr0_high) : "c"(0));
        avx2 = avx && (xcr0 & 6) == 6 && __get_cpuid_count(7, 0, &a, &b, &c, &d) && (b & bit_AVX2);
    }
    return avx2;
}
#endif

/* The loops for this CPU and output type. */
static Range *range_for(int single) {
#if PBK_AVX2
    if (has_avx2()) return single ? range_f32_avx2 : range_f64_avx2;
#endif
    return single ? range_f32 : range_f64;
}

static List *list_for(int single) {
#if PBK_AVX2
    if (has_avx2()) return single ? list_f32_avx2 : list_f64_avx2;
#endif
    return single ? list_f32 : list_f64;
}

/* One evaluation, shared by the calling thread and its helpers: the vertices are cut into chunks of about
 * equal work, which each thread claims in turn. The caller waits only for chunks a helper has claimed, so
 * a helper the system does not get to run in time costs nothing; the last thread out frees the job. */
typedef struct {
    Range *range;
    List *list;         /* with `work`: the grouped entry point's loop over listed vertices */
    const int32_t *work; /* the listed vertices; chunks then cut the list, not the vertices */
    const double *base;
    const int32_t *plain_start, *plain_key, *apex_start, *apex_key;
    const void *plain_coef, *apex_coef, *apex_scale, *rest_out;
    const uint64_t *vertex_mask;
    Tables tables;
    void *out;
    int n_chunks;
    int64_t *bounds; /* chunk c is the vertices bounds[c]:bounds[c + 1] */
    atomic_int next, finished, references;
} Job;

static void work_on(Job *job) {
    for (int c; (c = atomic_fetch_add(&job->next, 1)) < job->n_chunks;) {
        if (job->work)
            job->list(job->bounds[c], job->bounds[c + 1], job->work, job->base, job->plain_start, job->plain_key,
                      job->plain_coef, job->apex_start, job->apex_key, job->apex_coef, job->apex_scale,
                      &job->tables, job->out);
        else
            job->range(job->bounds[c], job->bounds[c + 1], job->base, job->plain_start, job->plain_key,
                       job->plain_coef, job->apex_start, job->apex_key, job->apex_coef, job->apex_scale,
                       job->rest_out, job->vertex_mask, &job->tables, job->out);
        atomic_fetch_add_explicit(&job->finished, 1, memory_order_release);
    }
}

static void release(Job *job) {
    if (atomic_fetch_sub(&job->references, 1) == 1) free(job);
}

static void *helper(void *arg) {
    work_on(arg);
    release(arg);
    return NULL;
}

/* Work before vertex v, an apex pair counting twice (it also takes a square root and a division). */
static int64_t cost(const int32_t *plain_start, const int32_t *apex_start, int64_t v) {
    return (int64_t)plain_start[v] + (apex_start ? 2 * (int64_t)apex_start[v] : 0);
}

/* The first vertex whose preceding work reaches `target` (cost grows with v). */
static int64_t split(const int32_t *plain_start, const int32_t *apex_start, int64_t n, int64_t target) {
    int64_t lo = 0, hi = n;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (cost(plain_start, apex_start, mid) < target)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* The grouped entry point's selection: the vertices of each group with a moved triangle go to `work`
 * (returned: how many), and a group that is still but not `fresh` (its vertices in `out` are not their result
 * at rest) gets its rest result copied and becomes fresh. A moving group is no longer fresh. */
static int64_t select_work(int single, int64_t n_groups, const uint64_t *group_mask, const int32_t *group_start,
                           const int32_t *group_vertex, const uint64_t *moved, const void *rest_out, uint8_t *fresh,
                           int32_t *work, void *out) {
    int64_t n_work = 0;
    for (int64_t g = 0; g < n_groups; ++g) {
        int32_t first = group_start[g], last = group_start[g + 1];
        if ((group_mask[2 * g] & moved[0]) | (group_mask[2 * g + 1] & moved[1])) {
            memcpy(work + n_work, group_vertex + first, sizeof(int32_t) * (size_t)(last - first));
            n_work += last - first;
            fresh[g] = 0;
        } else if (!fresh[g]) {
            for (int32_t i = first; i < last; ++i) {
                int64_t at = 3 * (int64_t)group_vertex[i];
                if (single)
                    memcpy((float *)out + at, (const float *)rest_out + at, 3 * sizeof(float));
                else
                    memcpy((double *)out + at, (const double *)rest_out + at, 3 * sizeof(double));
            }
            fresh[g] = 1;
        }
    }
    return n_work;
}

static int evaluate(int single, int64_t n_vertices, int64_t n_triangles, const double *control,
                    const double *control_rest, const double *rest_bases, const int32_t *triangles, const double *base,
                    const int32_t *plain_start, const int32_t *plain_key, const void *plain_coef,
                    const int32_t *apex_start, const int32_t *apex_key, const void *apex_coef,
                    const void *apex_scale, const double *apex_rest, const void *rest_out,
                    const uint64_t *vertex_mask, int64_t n_groups,
                    const uint64_t *group_mask, const int32_t *group_start, const int32_t *group_vertex,
                    uint8_t *fresh, int32_t *work, int32_t n_threads, void *out) {
    if (n_vertices < 0 || n_triangles < 0 || n_groups < 0 || n_threads < 1 || n_threads > PBK_MAX_THREADS) return 1;
    int max_chunks = n_threads == 1 ? 1 : CHUNKS_PER_THREAD * n_threads;
    /* one block: the job, the chunk bounds, then per triangle 12 plain and 18 apex Quads, 3 Gram terms and a byte */
    size_t head = sizeof(Job) + sizeof(int64_t) * (size_t)(max_chunks + 1);
    size_t per_triangle = 30 * sizeof(Quad) + 3 * sizeof(double) + 1;
    char *block = malloc(head + sizeof(Quad) + (size_t)n_triangles * per_triangle);
    if (!block) return 2;
    Job *job = (Job *)block;
    Quad *plain = (Quad *)(block + head + (sizeof(Quad) - (uintptr_t)(block + head) % sizeof(Quad)) % sizeof(Quad));
    Quad *apex = plain + 12 * n_triangles;
    double *gram = (double *)(apex + 18 * n_triangles);
    unsigned char *moved_triangle = (unsigned char *)(gram + 3 * n_triangles);
    *job = (Job){.range = range_for(single),
                 .list = list_for(single),
                 .base = base,
                 .plain_start = plain_start,
                 .plain_key = plain_key,
                 .apex_start = apex_start,
                 .apex_key = apex_key,
                 .plain_coef = plain_coef,
                 .apex_coef = apex_coef,
                 .apex_scale = apex_scale,
                 .rest_out = rest_out,
                 .vertex_mask = vertex_mask,
                 .tables = {.plain = plain,
                            .apex = apex,
                            .gram = gram,
                            .moved_triangle = moved_triangle,
                            .apex_rest = apex_rest},
                 .out = out,
                 .bounds = (int64_t *)(block + sizeof(Job))};
    build_tables(n_triangles, control, control_rest, rest_bases, triangles, plain, apex, gram, job->tables.shift, moved_triangle,
                 job->tables.moved);
    atomic_init(&job->next, 0);
    atomic_init(&job->finished, 0);
    atomic_init(&job->references, 1);
    if (group_start) { /* only the listed vertices are summed; chunks of about equal count */
        int64_t n_work = select_work(single, n_groups, group_mask, group_start, group_vertex, job->tables.moved,
                                     rest_out, fresh, work, out);
        int64_t work_cost = 0;
        for (int64_t w = 0; w < n_work && work_cost < PARALLEL_WORK; ++w)
            work_cost += cost(plain_start, apex_start, work[w] + 1) - cost(plain_start, apex_start, work[w]);
        if (work_cost < PARALLEL_WORK) n_threads = 1;
        job->work = work;
        job->n_chunks = n_threads == 1 ? 1 : max_chunks;
        for (int c = 0; c <= job->n_chunks; ++c) job->bounds[c] = n_work * c / job->n_chunks;
    } else {
        job->n_chunks = max_chunks;
        int64_t total = cost(plain_start, apex_start, n_vertices);
        for (int c = 0; c <= job->n_chunks; ++c)
            job->bounds[c] = c == job->n_chunks ? n_vertices
                                                : split(plain_start, apex_start, n_vertices, total * c / job->n_chunks);
    }
    int n_chunks = job->n_chunks;

    for (int i = 1; i < n_threads; ++i) {
        pthread_t thread;
        atomic_fetch_add(&job->references, 1);
        if (pthread_create(&thread, NULL, helper, job) == 0)
            pthread_detach(thread);
        else
            atomic_fetch_sub(&job->references, 1); /* no thread to be had: the caller does its share */
    }
    work_on(job);
    while (atomic_load_explicit(&job->finished, memory_order_acquire) < n_chunks) sched_yield();
    release(job);
    return 0;
}

/* out (N, 3) for the control points (M, 3) now and at rest. Returns 0; 1 for bad sizes or thread count
 * or 2 when memory ran out, leaving out untouched. The apex arrays are NULL in SoFFD mode. */
PBK_EXPORT int pbk_evaluate_f32(int64_t n_vertices, int64_t n_triangles, const double *control,
                                const double *control_rest, const double *rest_bases, const int32_t *triangles,
                                const double *base,
                                const int32_t *plain_start, const int32_t *plain_key, const float *plain_coef,
                                const int32_t *apex_start, const int32_t *apex_key, const float *apex_coef,
                                const float *apex_scale, const double *apex_rest, const float *rest_out, const uint64_t *vertex_mask,
                                int32_t n_threads, float *out) {
    return evaluate(1, n_vertices, n_triangles, control, control_rest, rest_bases, triangles, base, plain_start, plain_key,
                    plain_coef, apex_start, apex_key, apex_coef, apex_scale, apex_rest, rest_out, vertex_mask, 0, NULL, NULL, NULL,
                    NULL, NULL, n_threads, out);
}

PBK_EXPORT int pbk_evaluate_f64(int64_t n_vertices, int64_t n_triangles, const double *control,
                                const double *control_rest, const double *rest_bases, const int32_t *triangles,
                                const double *base,
                                const int32_t *plain_start, const int32_t *plain_key, const double *plain_coef,
                                const int32_t *apex_start, const int32_t *apex_key, const double *apex_coef,
                                const double *apex_scale, const double *apex_rest, const double *rest_out, const uint64_t *vertex_mask,
                                int32_t n_threads, double *out) {
    return evaluate(0, n_vertices, n_triangles, control, control_rest, rest_bases, triangles, base, plain_start, plain_key,
                    plain_coef, apex_start, apex_key, apex_coef, apex_scale, apex_rest, rest_out, vertex_mask, 0, NULL, NULL, NULL,
                    NULL, NULL, n_threads, out);
}

/* The grouped entry point, for a caller that keeps `out` from one call to the next (the add-on's face): the
 * vertices come in groups that have pairs with the same triangles (`group_mask`, like `vertex_mask`; group g
 * is the vertices group_vertex[group_start[g]:group_start[g + 1]]). Only the vertices of groups with a moved
 * triangle are summed; a still group is written (its result at rest) only when `fresh[g]` is 0, and then
 * marked 1. So the caller must zero `fresh` for every group whose vertices it changed in `out` itself.
 * `work` is scratch for N int32. Returns as pbk_evaluate_f32. */
PBK_EXPORT int pbk_evaluate_groups_f32(int64_t n_vertices, int64_t n_triangles, const double *control,
                                       const double *control_rest, const double *rest_bases, const int32_t *triangles,
                                const double *base,
                                       const int32_t *plain_start, const int32_t *plain_key, const float *plain_coef,
                                       const int32_t *apex_start, const int32_t *apex_key, const float *apex_coef,
                                       const float *apex_scale, const double *apex_rest, const float *rest_out, int64_t n_groups,
                                       const uint64_t *group_mask, const int32_t *group_start,
                                       const int32_t *group_vertex, uint8_t *fresh, int32_t *work, int32_t n_threads,
                                       float *out) {
    if (!group_mask || !group_start || !group_vertex || !fresh || !work) return 1;
    return evaluate(1, n_vertices, n_triangles, control, control_rest, rest_bases, triangles, base, plain_start, plain_key,
                    plain_coef, apex_start, apex_key, apex_coef, apex_scale, apex_rest, rest_out, NULL, n_groups, group_mask,
                    group_start, group_vertex, fresh, work, n_threads, out);
}

PBK_EXPORT int pbk_evaluate_groups_f64(int64_t n_vertices, int64_t n_triangles, const double *control,
                                       const double *control_rest, const double *rest_bases, const int32_t *triangles,
                                const double *base,
                                       const int32_t *plain_start, const int32_t *plain_key, const double *plain_coef,
                                       const int32_t *apex_start, const int32_t *apex_key, const double *apex_coef,
                                       const double *apex_scale, const double *apex_rest, const double *rest_out, int64_t n_groups,
                                       const uint64_t *group_mask, const int32_t *group_start,
                                       const int32_t *group_vertex, uint8_t *fresh, int32_t *work, int32_t n_threads,
                                       double *out) {
    if (!group_mask || !group_start || !group_vertex || !fresh || !work) return 1;
    return evaluate(0, n_vertices, n_triangles, control, control_rest, rest_bases, triangles, base, plain_start, plain_key,
                    plain_coef, apex_start, apex_key, apex_coef, apex_scale, apex_rest, rest_out, NULL, n_groups, group_mask,
                    group_start, group_vertex, fresh, work, n_threads, out);
}

#include "lip_guard.h"
#include "nearest_sources.h"
#include "bind_regions.h"
#include "lid_weights.h"
#include "unfold.h"

/* rest_bases (T, 7, 3) for the grouped and plain entry points: each triangle's basis V0, V1, V2, n, b0, b1, b2
 * (regions.deformation_basis) at the rest control points, made once per layout by this same code. */
PBK_EXPORT void pbk_bases(int64_t n_triangles, const double *control, const int32_t *triangles, double *bases) {
    for (int64_t t = 0; t < n_triangles; ++t) {
        Basis basis = triangle_basis(control, triangles + 3 * t);
        memcpy(bases + 21 * t, &basis, sizeof basis);
    }
}
