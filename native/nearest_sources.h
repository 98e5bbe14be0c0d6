/* lips._nearest_sources in C, included by planar_bones_kernel.c: the up-to-k nearest of some source vertices
 * along a mesh's edges, for every vertex within `radius` of one, by a Dijkstra from all sources at once. The
 * same steps as the Python (its notes say why they are right), and the same order: the heap pops (distance,
 * vertex, source row) in lexicographic order, as Python's heapq pops tuples, so ties fall the same way and the
 * two give the same lists. At set-up of a 68k-vertex face this takes 0.17 s in Python. */

typedef struct {
    double d;
    int32_t v, row;
} Reach;

static int reach_before(Reach a, Reach b) {
    if (a.d != b.d) return a.d < b.d;
    if (a.v != b.v) return a.v < b.v;
    return a.row < b.row;
}

typedef struct {
    Reach *items;
    int64_t size, capacity;
} ReachHeap;

static int heap_push(ReachHeap *heap, Reach item) {
    if (heap->size == heap->capacity) {
        int64_t capacity = heap->capacity ? 2 * heap->capacity : 1024;
        Reach *items = realloc(heap->items, (size_t)capacity * sizeof(Reach));
        if (!items) return 0;
        heap->items = items, heap->capacity = capacity;
    }
    int64_t i = heap->size++;
    while (i > 0) {
        int64_t parent = (i - 1) / 2;
        if (!reach_before(item, heap->items[parent])) break;
        heap->items[i] = heap->items[parent];
        i = parent;
    }
    heap->items[i] = item;
    return 1;
}

static Reach heap_pop(ReachHeap *heap) {
    Reach top = heap->items[0], last = heap->items[--heap->size];
    int64_t i = 0, n = heap->size;
    for (;;) {
        int64_t child = 2 * i + 1;
        if (child >= n) break;
        if (child + 1 < n && reach_before(heap->items[child + 1], heap->items[child])) ++child;
        if (!reach_before(heap->items[child], last)) break;
        heap->items[i] = heap->items[child];
        i = child;
    }
    if (n) heap->items[i] = last;
    return top;
}

static int holds_row(const int32_t *rows, int32_t count, int32_t row) {
    for (int32_t j = 0; j < count; ++j)
        if (rows[j] == row) return 1;
    return 0;
}

/* starts (n + 1), ends, length: the edges from each vertex (both ways); sources (n_sources,) vertices. Writes,
 * per vertex, count[v] entries (at most cap) of dist[v * cap + j] and row[v * cap + j], nearest first; count
 * must come zeroed. Returns 0, 1 for bad arguments, 2 when a vertex would hold more than cap (ties with the
 * k-th: the caller falls back to Python), 3 out of memory. */
PBK_EXPORT int pbk_nearest_sources(int64_t n, const int32_t *starts, const int32_t *ends, const double *length,
                                   int64_t n_sources, const int32_t *sources, int32_t k, double radius, double tie,
                                   int32_t cap, int32_t *count, double *dist, int32_t *row) {
    if (n < 0 || n_sources < 0 || k < 1 || cap < k) return 1;
    ReachHeap heap = {NULL, 0, 0};
    int status = 0;
    for (int64_t r = 0; r < n_sources && !status; ++r) {
        if (sources[r] < 0 || sources[r] >= n) status = 1;
        else if (!heap_push(&heap, (Reach){0.0, sources[r], (int32_t)r})) status = 3;
    }
    while (heap.size && !status) {
        Reach at = heap_pop(&heap);
        int32_t c = count[at.v];
        double *near = dist + (int64_t)at.v * cap;
        int32_t *rows = row + (int64_t)at.v * cap;
        if ((c >= k && at.d > near[k - 1] + tie) || holds_row(rows, c, at.row)) continue;
        if (c == cap) {
            status = 2;
            break;
        }
        near[c] = at.d, rows[c] = at.row, count[at.v] = c + 1;
        for (int32_t e = starts[at.v]; e < starts[at.v + 1]; ++e) {
            double du = at.d + length[e];
            if (du > radius) continue;
            int32_t u = ends[e], cu = count[u];
            const double *there = dist + (int64_t)u * cap;
            if (cu == 0 || ((cu < k || du <= there[k - 1] + tie) && !holds_row(row + (int64_t)u * cap, cu, at.row)))
                if (!heap_push(&heap, (Reach){du, u, at.row})) status = 3;
        }
    }
    free(heap.items);
    return status;
}
