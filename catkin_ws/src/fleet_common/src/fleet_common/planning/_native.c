/* The hot loops of the built-in solvers in C: PIBT's step and the breadth-first distance searches.
 *
 * `PIBTCore.step` is the inner loop of `pibt_step.PIBTStep.step`, move for move; `grow_row`
 * advances one distance search of `bfs.py` exactly as its numpy batches do.
 * The Python class stays the reference and the fallback (robots, machines
 * without a compiler): this file does exactly what its `step`, `_plan_agent`,
 * `_open`, `_pull`, `_swap_partner`, `_exits`, `_swap_required` and
 * `_swap_possible` do, in the same order, so both give the same plan for the
 * same seed (a property test holds them to it). Read the Python first; the
 * comments here only say where C differs in form.
 *
 * Distances are read from the uint16 table of `goal_distances` (row per
 * goal, column per free cell), shared with Python, never copied: lazy rows
 * that Python grows mid-step (through the `far` callback) are seen at once.
 * Per step, Python still makes the rows exact around the agents (`cover`)
 * and undoes rotations closed through fixed cells; this file does the rest.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdint.h>
#include <string.h>

#define NIL (-1)
#define MAX_MOVES 5 /* stay + 4 neighbours */

typedef struct {
    int agent, k, partner, ncands;
    int32_t cands[MAX_MOVES];
} Frame;

typedef struct {
    PyObject_HEAD
    Py_ssize_t cells, agents;
    int32_t *moves;   /* cells x MAX_MOVES: the cell, then its free neighbours (Grid.adjacency order) */
    uint8_t *nmoves;  /* per cell, how many of those */
    int32_t *goals;   /* per agent, its goal cell */
    int32_t *row_of;  /* per agent, its row of the table */
    Py_buffer table;  /* uint16 rows x stride */
    Py_ssize_t stride;
    PyObject *limit;  /* the Python list AgentDistances keeps (far() updates it) */
    PyObject **ids;   /* per cell, one int object: configurations share them, as the Python step's do
                         (PIBT keeps every configuration as a list: a new int per entry tripled its memory) */
    PyObject *far;    /* AgentDistances.far, or None for complete tables */
    int swap, rotations;
    /* per step */
    int32_t *occ_now, *occ_nxt, *q_from, *q_to, *order, *claimed;
    Py_ssize_t nclaimed;
    Frame *stack;
    int failed;       /* a Python exception is set (from far) */
} Core;

static inline long dist(Core *c, int agent, int cell) {
    const uint16_t *t = (const uint16_t *)c->table.buf;
    return t[(Py_ssize_t)c->row_of[agent] * c->stride + cell];
}

static long far_dist(Core *c, int agent, int cell) {
    if (c->failed) return 0;
    if (c->far == Py_None) return dist(c, agent, cell);
    PyObject *r = PyObject_CallFunction(c->far, "ii", agent, cell);
    if (r == NULL) { c->failed = 1; return 0; }
    long d = PyLong_AsLong(r);
    Py_DECREF(r);
    if (d == -1 && PyErr_Occurred()) c->failed = 1;
    return d;
}

static long limit_of(Core *c, int agent) {
    PyObject *v = PyList_GetItem(c->limit, agent); /* borrowed */
    if (v == NULL) { c->failed = 1; return 0; }
    long d = PyLong_AsLong(v);
    if (d == -1 && PyErr_Occurred()) c->failed = 1;
    return d;
}

static inline void claim(Core *c, int cell, int agent) {
    c->occ_nxt[cell] = agent;
    c->claimed[c->nclaimed++] = cell;
}

static int exits(Core *c, int cell, int came_from, int32_t *out) {
    int n = 0;
    const int32_t *m = c->moves + (Py_ssize_t)cell * MAX_MOVES;
    for (int k = 1; k < c->nmoves[cell]; k++) {
        int u = m[k];
        if (u == came_from) continue;
        int a = c->occ_now[u];
        if (a != NIL && c->nmoves[u] == 2 && c->goals[a] == u) continue;
        out[n++] = u;
    }
    return n;
}

static int swap_required(Core *c, int pusher, int puller, int at_pusher, int at_puller) {
    int32_t ex[4];
    while (dist(c, pusher, at_puller) < dist(c, pusher, at_pusher)) {
        int n = exits(c, at_puller, at_pusher, ex);
        if (n >= 2) return 0;
        if (n == 0) break;
        at_pusher = at_puller;
        at_puller = ex[0];
    }
    long lim = limit_of(c, puller);
    if (c->failed) return 0;
    int push_ok;
    if (dist(c, puller, at_puller) > lim) {
        long a = far_dist(c, puller, at_pusher);
        if (c->failed) return 0;
        long b = far_dist(c, puller, at_puller);
        if (c->failed || !(a < b)) return 0;
    } else if (!(dist(c, puller, at_pusher) < dist(c, puller, at_puller))) {
        return 0;
    }
    push_ok = dist(c, pusher, at_pusher) == 0 || dist(c, pusher, at_puller) < dist(c, pusher, at_pusher);
    return push_ok;
}

static int swap_possible(Core *c, int at_follower, int at_leader) {
    int32_t ex[4];
    int origin = at_follower, behind = at_follower, ahead = at_leader;
    for (Py_ssize_t i = 0; i < c->cells; i++) {
        if (ahead == origin) return 0;
        int n = exits(c, ahead, behind, ex);
        if (n >= 2) return 1;
        if (n == 0) return 0;
        behind = ahead;
        ahead = ex[0];
    }
    return 0;
}

static int swap_partner(Core *c, int i, int best) {
    int here = c->q_from[i];
    if (best == here) return NIL;
    int j = c->occ_now[best];
    if (j != NIL && c->q_to[j] == NIL && swap_required(c, i, j, here, best) && swap_possible(c, best, here))
        return j;
    if (c->failed) return NIL;
    const int32_t *m = c->moves + (Py_ssize_t)here * MAX_MOVES;
    for (int n = 1; n < c->nmoves[here]; n++) {
        int u = m[n];
        int k = c->occ_now[u];
        if (k == NIL || u == best || c->q_to[k] != NIL) continue;
        if (dist(c, k, best) < dist(c, k, here) && swap_required(c, k, i, here, best) && swap_possible(c, best, here))
            return k;
        if (c->failed) return NIL;
    }
    return NIL;
}

/* Candidates of agent i into f, best first (reversed when it leads a swap), and its partner. */
static void open_frame(Core *c, int i, long salt, Frame *f) {
    int v = c->q_from[i], m = c->nmoves[v];
    const int32_t *mv = c->moves + (Py_ssize_t)v * MAX_MOVES;
    long r = (salt + i) % m;
    long keys[MAX_MOVES];
    for (int k = 0; k < m; k++) {
        f->cands[k] = mv[(r + k) % m];
        keys[k] = dist(c, i, f->cands[k]);
    }
    for (int k = 1; k < m; k++) { /* insertion sort: stable, as Python's sorted */
        int32_t cell = f->cands[k];
        long key = keys[k];
        int p = k - 1;
        while (p >= 0 && keys[p] > key) {
            f->cands[p + 1] = f->cands[p];
            keys[p + 1] = keys[p];
            p--;
        }
        f->cands[p + 1] = cell;
        keys[p + 1] = key;
    }
    f->ncands = m;
    f->agent = i;
    f->k = 0;
    f->partner = c->swap ? swap_partner(c, i, f->cands[0]) : NIL;
    if (f->partner != NIL) {
        for (int a = 0, b = m - 1; a < b; a++, b--) {
            int32_t t = f->cands[a];
            f->cands[a] = f->cands[b];
            f->cands[b] = t;
        }
    }
}

static void pull(Core *c, const Frame *f) {
    int here = c->q_from[f->agent];
    if (f->partner != NIL && f->k == 1 && c->q_to[f->partner] == NIL && c->occ_nxt[here] == NIL) {
        c->q_to[f->partner] = here;
        claim(c, here, f->partner);
    }
}

static int plan_agent(Core *c, int agent, long salt) {
    Frame *stack = c->stack;
    Py_ssize_t depth = 0;
    int bottom = c->rotations ? NIL : agent;
    Frame *f = &stack[0];
    open_frame(c, agent, salt, f);
    for (;;) {
        if (c->failed) return 0;
        int here = c->q_from[f->agent];
        int pushed = 0;
        while (f->k < f->ncands) {
            int v = f->cands[f->k++];
            if (c->occ_nxt[v] != NIL) continue;
            int j = c->occ_now[v];
            if (j != NIL && c->q_to[j] == here) continue;
            if (j == bottom && j != NIL && depth > 0) continue;
            c->q_to[f->agent] = v;
            claim(c, v, f->agent);
            if (j == NIL || j == f->agent || c->q_to[j] != NIL) {
                for (Py_ssize_t d = depth; d >= 0; d--) pull(c, &stack[d]);
                return 1;
            }
            depth++;
            f = &stack[depth];
            open_frame(c, j, salt, f);
            pushed = 1;
            break;
        }
        if (pushed) continue;
        int holder = c->occ_nxt[here];
        c->q_to[f->agent] = here;
        claim(c, here, f->agent);
        if (depth == 0) return holder == NIL;
        depth--;
        f = &stack[depth];
    }
}

/* One entry of a buffer of integers in native byte order (format h, H, i, I, l, L, q or Q);
 * -1 for another format or an unsigned entry too large for long long. */
static int buffer_int(const Py_buffer *view, char kind, Py_ssize_t k, long long *v) {
    const char *at = (const char *)view->buf + k * view->itemsize;
    switch (kind) {
    case 'h': *v = *(const int16_t *)at; return 0;
    case 'H': *v = *(const uint16_t *)at; return 0;
    case 'i': *v = *(const int32_t *)at; return 0;
    case 'I': *v = *(const uint32_t *)at; return 0;
    case 'l': case 'q': if (view->itemsize == 8) { *v = *(const int64_t *)at; return 0; }
                        if (view->itemsize == 4) { *v = *(const int32_t *)at; return 0; } break;
    case 'L': case 'Q': if (view->itemsize == 4) { *v = *(const uint32_t *)at; return 0; }
                        if (view->itemsize == 8 && *(const uint64_t *)at <= INT64_MAX) {
                            *v = (long long)*(const uint64_t *)at;
                            return 0;
                        }
                        break;
    }
    return -1;
}

/* Whether `len` entries are what the caller wants: exactly `n`, or (exact = 0) at most `n`. */
static int length_ok(Py_ssize_t len, Py_ssize_t n, int exact, const char *what) {
    if (exact ? len == n : len <= n) return 1;
    PyErr_Format(PyExc_ValueError, "%s: %zd entries, expected %s%zd", what, len, exact ? "" : "at most ", n);
    return 0;
}

static int store_int(long long v, int32_t *out, const char *what) {
    if (v < INT32_MIN || v > INT32_MAX) {
        PyErr_Format(PyExc_ValueError, "%s: an entry outside 32-bit integers", what);
        return 0;
    }
    *out = (int32_t)v;
    return 1;
}

/* Reads `seq` into `out`: exactly `n` ints, or (exact = 0) up to `n`; returns how many, -1 on error.
 * A buffer of integers (array 'H'/'I', memoryview.cast, a numpy array) is read in place: LaCAM
 * keeps its configurations packed, and would otherwise pay for a list of int objects per step.
 * Any other sequence is read item by item. */
static Py_ssize_t read_ints(PyObject *seq, int32_t *out, Py_ssize_t n, int exact, const char *what) {
    Py_ssize_t len, i;
    if (PyObject_CheckBuffer(seq)) {
        Py_buffer view;
        if (PyObject_GetBuffer(seq, &view, PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0) return -1;
        const char *f = view.format != NULL ? view.format : "B";
        if (*f == '@' || *f == '=') f++;
        len = view.ndim == 1 ? view.shape[0] : -1;
        if (len < 0 || f[0] == 0 || f[1] != 0 || strchr("hHiIlLqQ", f[0]) == NULL) {
            PyErr_Format(PyExc_TypeError, "%s: a 1-D buffer of integers expected, got format '%s'", what,
                         view.format != NULL ? view.format : "B");
            len = -1;
        } else if (!length_ok(len, n, exact, what)) {
            len = -1;
        }
        for (i = 0; i < len; i++) {
            long long v;
            if (buffer_int(&view, f[0], i, &v) < 0) v = (long long)INT32_MAX + 1; /* too large for long long */
            if (!store_int(v, &out[i], what)) { len = -1; break; }
        }
        PyBuffer_Release(&view);
        return len;
    }
    PyObject *fast = PySequence_Fast(seq, what);
    if (fast == NULL) return -1;
    len = PySequence_Fast_GET_SIZE(fast);
    if (!length_ok(len, n, exact, what)) len = -1;
    PyObject **items = PySequence_Fast_ITEMS(fast);
    for (i = 0; i < len; i++) {
        long long v = PyLong_AsLongLong(items[i]);
        if ((v == -1 && PyErr_Occurred()) || !store_int(v, &out[i], what)) { len = -1; break; }
    }
    Py_DECREF(fast);
    return len;
}

/* step(q_from, q_to, order, salt) -> (ok, fixed); see PIBTStep.step (cover and rotations stay in Python). */
static PyObject *Core_step(Core *c, PyObject *args) {
    PyObject *q_from_obj, *q_to_obj, *order_obj;
    long salt;
    if (!PyArg_ParseTuple(args, "OO!Ol", &q_from_obj, &PyList_Type, &q_to_obj, &order_obj, &salt)) return NULL;
    Py_ssize_t n = c->agents;
    if (read_ints(q_from_obj, c->q_from, n, 1, "q_from") < 0 || read_ints(q_to_obj, c->q_to, n, 1, "q_to") < 0)
        return NULL;
    Py_ssize_t norder = read_ints(order_obj, c->order, n, 0, "order");
    if (norder < 0) return NULL;
    for (Py_ssize_t i = 0; i < n; i++) {
        if (c->q_from[i] < 0 || c->q_from[i] >= c->cells || c->q_to[i] < NIL || c->q_to[i] >= c->cells) {
            PyErr_SetString(PyExc_ValueError, "a cell id outside the free cells");
            return NULL;
        }
    }
    int32_t *q_from = c->q_from, *q_to = c->q_to, *occ_now = c->occ_now, *occ_nxt = c->occ_nxt;
    c->nclaimed = 0;
    c->failed = 0;
    int ok = 1;
    for (Py_ssize_t i = 0; i < n; i++) occ_now[q_from[i]] = (int32_t)i;
    for (Py_ssize_t i = 0; i < n; i++) {
        int v = q_to[i];
        if (v == NIL) continue;
        int j = occ_now[v];
        if (occ_nxt[v] != NIL || (j != NIL && j != i && q_to[j] == q_from[i])) { ok = 0; break; }
        claim(c, v, (int)i);
    }
    Py_ssize_t fixed = c->nclaimed;
    if (ok) {
        for (Py_ssize_t k = 0; k < norder; k++) {
            long i = c->order[k];
            if (i < 0 || i >= n) {
                PyErr_SetString(PyExc_ValueError, "an agent outside the agents");
                c->failed = 1;
                break;
            }
            if (q_to[i] != NIL) continue;
            int v = q_from[i];
            if (v == c->goals[i] && occ_nxt[v] == NIL) {
                q_to[i] = v;
                claim(c, v, (int)i);
            } else if (!plan_agent(c, (int)i, salt)) {
                ok = 0;
                break;
            }
        }
        if (ok && !c->failed)
            for (Py_ssize_t i = 0; i < n; i++)
                if (q_to[i] == NIL) q_to[i] = q_from[i];
    }
    for (Py_ssize_t i = 0; i < n; i++) occ_now[q_from[i]] = NIL;
    for (Py_ssize_t k = 0; k < c->nclaimed; k++) occ_nxt[c->claimed[k]] = NIL;
    if (c->failed) return NULL;
    if (ok) {
        for (Py_ssize_t i = 0; i < n; i++) {
            PyObject *v = c->ids[q_to[i]];
            Py_INCREF(v);
            PyList_SetItem(q_to_obj, i, v); /* steals the new reference */
        }
    }
    return Py_BuildValue("(Nn)", PyBool_FromLong(ok), fixed);
}

static void Core_dealloc(Core *c) {
    if (c->table.obj != NULL) PyBuffer_Release(&c->table);
    Py_XDECREF(c->limit);
    Py_XDECREF(c->far);
    if (c->ids != NULL)
        for (Py_ssize_t v = 0; v < c->cells; v++) Py_XDECREF(c->ids[v]);
    PyMem_Free(c->ids);
    PyMem_Free(c->moves);
    PyMem_Free(c->nmoves);
    PyMem_Free(c->goals);
    PyMem_Free(c->row_of);
    PyMem_Free(c->occ_now);
    PyMem_Free(c->occ_nxt);
    PyMem_Free(c->q_from);
    PyMem_Free(c->q_to);
    PyMem_Free(c->order);
    PyMem_Free(c->claimed);
    PyMem_Free(c->stack);
    Py_TYPE(c)->tp_free((PyObject *)c);
}

/* PIBTCore(moves, goals, row_of, table, limit, far, swap, rotations) */
static int Core_init(Core *c, PyObject *args, PyObject *kwds) {
    PyObject *moves, *goals, *row_of, *table, *limit, *far;
    int swap, rotations;
    (void)kwds;
    if (c->moves != NULL) {
        PyErr_SetString(PyExc_TypeError, "PIBTCore is initialised once");
        return -1;
    }
    if (!PyArg_ParseTuple(args, "OOOOO!Opp", &moves, &goals, &row_of, &table, &PyList_Type, &limit, &far, &swap,
                          &rotations))
        return -1;
    if (PyObject_GetBuffer(table, &c->table, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_ND) < 0) return -1;
    if (c->table.ndim != 2 || c->table.itemsize != 2 || c->table.format == NULL || strcmp(c->table.format, "H") != 0) {
        PyErr_SetString(PyExc_TypeError, "table: a C-contiguous 2-D uint16 array expected");
        return -1;
    }
    c->stride = c->table.shape[1];
    Py_ssize_t rows = c->table.shape[0];
    PyObject *mv = PySequence_Fast(moves, "moves");
    if (mv == NULL) return -1;
    Py_ssize_t cells = PySequence_Fast_GET_SIZE(mv);
    Py_ssize_t n = PySequence_Size(goals);
    if (n < 0) { Py_DECREF(mv); return -1; }
    if (cells >= c->stride) {
        Py_DECREF(mv);
        PyErr_SetString(PyExc_ValueError, "table: fewer columns than cells");
        return -1;
    }
    c->cells = cells;
    c->agents = n;
    c->moves = PyMem_Calloc((size_t)cells * MAX_MOVES + 1, sizeof(int32_t));
    c->nmoves = PyMem_Calloc((size_t)cells + 1, 1);
    c->goals = PyMem_Calloc((size_t)n + 1, sizeof(int32_t));
    c->row_of = PyMem_Calloc((size_t)n + 1, sizeof(int32_t));
    c->occ_now = PyMem_Malloc(((size_t)cells + 1) * sizeof(int32_t));
    c->occ_nxt = PyMem_Malloc(((size_t)cells + 1) * sizeof(int32_t));
    c->q_from = PyMem_Calloc((size_t)n + 1, sizeof(int32_t));
    c->q_to = PyMem_Calloc((size_t)n + 1, sizeof(int32_t));
    c->order = PyMem_Calloc((size_t)n + 1, sizeof(int32_t));
    /* an agent's frame opens once: it claims at most each candidate, its own cell, a pull and a fixed cell */
    c->claimed = PyMem_Calloc((size_t)n * (MAX_MOVES + 3) + 1, sizeof(int32_t));
    c->stack = PyMem_Calloc((size_t)n + 1, sizeof(Frame));
    if (!c->moves || !c->nmoves || !c->goals || !c->row_of || !c->occ_now || !c->occ_nxt || !c->q_from ||
        !c->q_to || !c->order || !c->claimed || !c->stack) {
        Py_DECREF(mv);
        PyErr_NoMemory();
        return -1;
    }
    for (Py_ssize_t v = 0; v <= cells; v++) c->occ_now[v] = c->occ_nxt[v] = NIL;
    for (Py_ssize_t v = 0; v < cells; v++) {
        PyObject *row = PySequence_Fast(PySequence_Fast_GET_ITEM(mv, v), "moves[cell]");
        if (row == NULL) { Py_DECREF(mv); return -1; }
        Py_ssize_t m = PySequence_Fast_GET_SIZE(row);
        if (m < 1 || m > MAX_MOVES) {
            Py_DECREF(row);
            Py_DECREF(mv);
            PyErr_SetString(PyExc_ValueError, "moves[cell]: 1 to 5 cells expected");
            return -1;
        }
        for (Py_ssize_t k = 0; k < m; k++) {
            long u = PyLong_AsLong(PySequence_Fast_GET_ITEM(row, k));
            if ((u == -1 && PyErr_Occurred()) || u < 0 || u >= cells) {
                Py_DECREF(row);
                Py_DECREF(mv);
                if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "moves[cell]: a cell outside the free cells");
                return -1;
            }
            c->moves[v * MAX_MOVES + k] = (int32_t)u;
        }
        c->nmoves[v] = (uint8_t)m;
        Py_DECREF(row);
    }
    Py_DECREF(mv);
    if (read_ints(goals, c->goals, n, 1, "goals") < 0 || read_ints(row_of, c->row_of, n, 1, "row_of") < 0) return -1;
    for (Py_ssize_t i = 0; i < n; i++) {
        if (c->row_of[i] < 0 || c->row_of[i] >= rows || c->goals[i] < 0 || c->goals[i] >= cells) {
            PyErr_SetString(PyExc_ValueError, "goals/row_of: outside the free cells or the table");
            return -1;
        }
    }
    if (PyList_GET_SIZE(limit) != n) {
        PyErr_SetString(PyExc_ValueError, "limit: one entry per agent expected");
        return -1;
    }
    Py_INCREF(limit);
    c->limit = limit;
    Py_INCREF(far);
    c->far = far;
    c->ids = PyMem_Calloc((size_t)cells + 1, sizeof(PyObject *));
    if (c->ids == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    for (Py_ssize_t v = 0; v < cells; v++) {
        c->ids[v] = PyLong_FromSsize_t(v);
        if (c->ids[v] == NULL) return -1;
    }
    c->swap = swap;
    c->rotations = rotations;
    return 0;
}

static PyMethodDef Core_methods[] = {
    {"step", (PyCFunction)Core_step, METH_VARARGS,
     "step(q_from, q_to, order, salt) -> (ok, fixed): fill q_to's NIL entries by PIBT."},
    {NULL, NULL, 0, NULL},
};

static PyTypeObject CoreType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "fleet_common.planning._native.PIBTCore",
    .tp_basicsize = sizeof(Core),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "PIBT steps over one grid's free cells and one set of goals (see pibt_step).",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Core_init,
    .tp_dealloc = (destructor)Core_dealloc,
    .tp_methods = Core_methods,
};

/* ---- breadth-first distance searches (see bfs.py, the reference) ---- */

/* grow_row(table, neighbours, row, frontier, level, stop, target, margin) -> (frontier, level): one
 * resumable search of bfs.py (`Search`), advanced as `bfs.grow_in_numpy` advances it. Row `row` is
 * exact up to `level`; `frontier` (bytes or array of int64 free-cell ids) holds the cells at that
 * level. Each round: a reached `target` (-1: none) lowers `stop` to its distance + margin; at
 * `stop` the search pauses; else one more level. Returns the new frontier (int64 bytes, empty
 * once every reachable cell has its distance) and level. */
static PyObject *grow_row(PyObject *self, PyObject *args) {
    PyObject *table_obj, *nb_obj, *frontier_obj;
    Py_ssize_t r;
    long level, stop, target, margin;
    (void)self;
    if (!PyArg_ParseTuple(args, "OOnOllll", &table_obj, &nb_obj, &r, &frontier_obj, &level, &stop, &target, &margin))
        return NULL;
    Py_buffer table, nb, fr;
    if (PyObject_GetBuffer(table_obj, &table, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_ND | PyBUF_WRITABLE) < 0)
        return NULL;
    if (PyObject_GetBuffer(nb_obj, &nb, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_ND) < 0) {
        PyBuffer_Release(&table);
        return NULL;
    }
    if (PyObject_GetBuffer(frontier_obj, &fr, PyBUF_C_CONTIGUOUS) < 0) {
        PyBuffer_Release(&nb);
        PyBuffer_Release(&table);
        return NULL;
    }
    PyObject *out = NULL;
    int64_t *cur = NULL, *nxt = NULL;
    if (table.ndim != 2 || table.itemsize != 2 || strcmp(table.format, "H") != 0 || nb.ndim != 2 ||
        nb.itemsize != 4 || (strcmp(nb.format, "i") != 0 && strcmp(nb.format, "=i") != 0) || nb.shape[1] != 4 ||
        nb.shape[0] != table.shape[1] || fr.len % 8 != 0) {
        PyErr_SetString(PyExc_TypeError, "grow_row: a uint16 (rows, F+1) table, int32 (F+1, 4) neighbours and "
                                         "an int64 frontier expected");
        goto done;
    }
    Py_ssize_t cells = nb.shape[0] - 1, n = fr.len / 8;
    if (r < 0 || r >= table.shape[0] || target < -1 || target >= cells || n > cells || level < 0) {
        PyErr_SetString(PyExc_ValueError, "grow_row: a row, target or level out of range");
        goto done;
    }
    const int32_t *next = (const int32_t *)nb.buf;
    uint16_t *row = (uint16_t *)table.buf + r * table.shape[1];
    cur = PyMem_Malloc(((size_t)cells + 1) * sizeof(int64_t));
    nxt = PyMem_Malloc(((size_t)cells + 1) * sizeof(int64_t));
    if (cur == NULL || nxt == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    memcpy(cur, fr.buf, (size_t)fr.len);
    for (Py_ssize_t k = 0; k < n; k++) {
        if (cur[k] < 0 || cur[k] >= cells) {
            PyErr_SetString(PyExc_ValueError, "grow_row: a frontier cell outside the free cells");
            goto done;
        }
    }
    for (;;) {
        if (target >= 0 && row[target] != 65535 && (long)row[target] + margin < stop) stop = (long)row[target] + margin;
        if (level >= stop || n == 0) break;
        level++;
        if (level >= 65534) {
            PyErr_SetString(PyExc_ValueError, "a shortest path on this map is 65534 moves or longer; "
                                              "distance tables hold at most 65533");
            goto done;
        }
        Py_ssize_t m = 0;
        for (Py_ssize_t k = 0; k < n; k++) {
            const int32_t *e = next + cur[k] * 4;
            for (int d = 0; d < 4; d++) {
                int32_t u = e[d];
                if (row[u] == 65535) { /* the sentinel column holds 0: never taken */
                    row[u] = (uint16_t)level;
                    nxt[m++] = u;
                }
            }
        }
        int64_t *t = cur;
        cur = nxt;
        nxt = t;
        n = m;
    }
    out = Py_BuildValue("(y#l)", (const char *)cur, (Py_ssize_t)(n * 8), level);
done:
    PyMem_Free(cur);
    PyMem_Free(nxt);
    PyBuffer_Release(&fr);
    PyBuffer_Release(&nb);
    PyBuffer_Release(&table);
    return out;
}

static PyMethodDef module_methods[] = {
    {"grow_row", grow_row, METH_VARARGS,
     "grow_row(table, neighbours, row, frontier, level, stop, target, margin) -> (frontier, level)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_native", "The built-in solvers' hot loops in C (pibt_step.py and bfs.py are the reference).",
    -1, module_methods, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__native(void) {
    if (PyType_Ready(&CoreType) < 0) return NULL;
    PyObject *m = PyModule_Create(&module);
    if (m == NULL) return NULL;
    Py_INCREF(&CoreType);
    if (PyModule_AddObject(m, "PIBTCore", (PyObject *)&CoreType) < 0) {
        Py_DECREF(&CoreType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
