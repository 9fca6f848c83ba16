/*
 * The morph's per-pixel kernels (miketalk.morph): forward splat, hole-aware
 * blend and scanline hole filling, for one frame.
 *
 * A plain C extension (buffer protocol only, no numpy headers) so that a
 * process pays nothing to load them: `miketalk say` renders its first frame
 * as soon as Festival has spoken. The arithmetic is the reference: every
 * value is computed in double precision in the order written here and
 * rounded half up by truncating `v + 0.5` to uint8.
 *
 * No checks on values: miketalk.morph passes C-contiguous arrays of the
 * right types and sizes; this module checks only the buffers' layout, item
 * sizes and shapes, so that a wrong call raises instead of reading out of
 * bounds. The GIL is released while a kernel runs.
 */

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdint.h>
#include <string.h>

#define HOLE_VALUE 0
#define NO_SOURCE (-1)

/* ------------------------------------------------------------------------- */
/* kernels                                                                   */
/* ------------------------------------------------------------------------- */

/* Forward-splat source indices along scale * flow into index (-1 = hole). On a
 * collision the larger priority wins, ties going to the later pixel in scan
 * order; depth holds the winning priority so far.
 *
 * Each row goes in blocks: a loop without branches (which the compiler
 * vectorises) computes the destinations, then a scalar loop scatters them. */
#define SPLAT_BLOCK 256

static void splat(const float *flow, const float *priority, double scale, int32_t *index,
                  float *depth, Py_ssize_t h, Py_ssize_t w)
{
    const Py_ssize_t n = h * w;
    const double wd = (double)w, hd = (double)h;
    Py_ssize_t dest[SPLAT_BLOCK];
    for (Py_ssize_t i = 0; i < n; i++) {
        index[i] = NO_SOURCE;
        depth[i] = -1.0f;
    }
    for (Py_ssize_t y = 0; y < h; y++) {
        for (Py_ssize_t x0 = 0; x0 < w; x0 += SPLAT_BLOCK) {
            const Py_ssize_t len = w - x0 < SPLAT_BLOCK ? w - x0 : SPLAT_BLOCK;
            const float *f = flow + 2 * (y * w + x0);
            for (Py_ssize_t k = 0; k < len; k++) {
                /* RND(t) = floor(t + 0.5) lands in [0, w) exactly when t + 0.5 does,
                 * and there truncation is floor */
                const double fx = (double)(x0 + k) + scale * (double)f[2 * k] + 0.5;
                const double fy = (double)y + scale * (double)f[2 * k + 1] + 0.5;
                const int inside = (fx >= 0.0) & (fx < wd) & (fy >= 0.0) & (fy < hd);
                dest[k] = inside ? (Py_ssize_t)fy * w + (Py_ssize_t)fx : -1;
            }
            for (Py_ssize_t k = 0; k < len; k++) {
                const Py_ssize_t q = dest[k], i = y * w + x0 + k;
                if (q < 0)
                    continue;
                const float p = priority[i];
                if (p >= depth[q]) {
                    depth[q] = p;
                    index[q] = (int32_t)i;
                }
            }
        }
    }
}

/* Blend row y of the two splats into out (H, W, C); mark holes. w0[v] and w1[v]
 * are (1 - alpha) * v and alpha * v in double precision (tables of the 256
 * values: the same products, looked up). Inlined with a constant nc (1 or 3)
 * so that the channel loops unroll. */
static inline __attribute__((always_inline)) void
blend_row_nc(const uint8_t *pixels0, const uint8_t *pixels1, const int32_t *index0,
             const int32_t *index1, const double *w0, const double *w1, int hole_aware,
             uint8_t *out, uint8_t *hole, Py_ssize_t y, Py_ssize_t w, const Py_ssize_t nc)
{
    for (Py_ssize_t x = 0; x < w; x++) {
        const Py_ssize_t q = y * w + x;
        const int32_t i0 = index0[q], i1 = index1[q];
        uint8_t *o = out + q * nc;
        hole[q] = (i0 < 0 && i1 < 0);
        if (i0 >= 0 && i1 >= 0) {
            const uint8_t *p0 = pixels0 + (Py_ssize_t)i0 * nc, *p1 = pixels1 + (Py_ssize_t)i1 * nc;
            for (Py_ssize_t c = 0; c < nc; c++)
                o[c] = (uint8_t)(w0[p0[c]] + w1[p1[c]] + 0.5);
        } else if (i0 >= 0) {
            const uint8_t *p0 = pixels0 + (Py_ssize_t)i0 * nc;
            for (Py_ssize_t c = 0; c < nc; c++)
                o[c] = hole_aware ? p0[c] : (uint8_t)(w0[p0[c]] + 0.5);
        } else if (i1 >= 0) {
            const uint8_t *p1 = pixels1 + (Py_ssize_t)i1 * nc;
            for (Py_ssize_t c = 0; c < nc; c++)
                o[c] = hole_aware ? p1[c] : (uint8_t)(w1[p1[c]] + 0.5);
        } else {
            for (Py_ssize_t c = 0; c < nc; c++)
                o[c] = HOLE_VALUE;
        }
    }
}

static void blend_row(const uint8_t *pixels0, const uint8_t *pixels1, const int32_t *index0,
                      const int32_t *index1, const double *w0, const double *w1, int hole_aware,
                      uint8_t *out, uint8_t *hole, Py_ssize_t y, Py_ssize_t w, Py_ssize_t nc)
{
    if (nc == 3)
        blend_row_nc(pixels0, pixels1, index0, index1, w0, w1, hole_aware, out, hole, y, w, 3);
    else if (nc == 1)
        blend_row_nc(pixels0, pixels1, index0, index1, w0, w1, hole_aware, out, hole, y, w, 1);
    else
        blend_row_nc(pixels0, pixels1, index0, index1, w0, w1, hole_aware, out, hole, y, w, nc);
}

/* Fill items start:stop of a sequence of items of `size` bytes each, laid end to
 * end from `base`, by linear interpolation between items `left` and `right`; -1
 * means that end is the sequence's edge (the other end's value is extended).
 * The items are pixels of a row (size C) or whole rows of the image (size W * C). */
static void lerp_items(uint8_t *base, Py_ssize_t size, Py_ssize_t start, Py_ssize_t stop,
                       Py_ssize_t left, Py_ssize_t right)
{
    if (left < 0)
        left = right;
    if (right < 0)
        right = left;
    const Py_ssize_t span = right - left;
    const uint8_t *lo = base + left * size, *hi = base + right * size;
    for (Py_ssize_t k = start; k < stop; k++) {
        const double t = span != 0 ? (double)(k - left) / (double)span : 0.0;
        uint8_t *o = base + k * size;
        for (Py_ssize_t c = 0; c < size; c++) {
            const double l = (double)lo[c];
            o[c] = (uint8_t)(l + t * ((double)hi[c] - l) + 0.5);
        }
    }
}

/* Fill every run of items marked in `mask` (count items of `size` bytes from
 * `base`) between the unmarked items at its ends; returns 1, filling nothing,
 * when every item is marked (nothing to fill from). */
static int fill_runs(uint8_t *base, const uint8_t *mask, Py_ssize_t count, Py_ssize_t size)
{
    Py_ssize_t last = -1; /* last unmarked item seen */
    Py_ssize_t k = 0;
    while (k < count) {
        if (!mask[k]) {
            last = k++;
            continue;
        }
        const Py_ssize_t start = k;
        while (k < count && mask[k])
            k++;
        if (last < 0 && k == count)
            return 1;
        lerp_items(base, size, start, k, last, k < count ? k : -1);
    }
    return 0;
}

/* Fill the holes of row y; returns 1 if the row had no non-hole pixel. */
static int fill_row(uint8_t *out, const uint8_t *hole, Py_ssize_t y, Py_ssize_t w, Py_ssize_t nc)
{
    return fill_runs(out + y * w * nc, hole + y * w, w, nc);
}

/* Fill rows with no data in the column direction; returns 0 if every row is empty. */
static int fill_empty_rows(uint8_t *out, const uint8_t *empty_row, Py_ssize_t h, Py_ssize_t w,
                           Py_ssize_t nc)
{
    return !fill_runs(out, empty_row, h, w * nc);
}

/* ------------------------------------------------------------------------- */
/* buffer checks                                                             */
/* ------------------------------------------------------------------------- */

typedef struct {
    const char *name;
    Py_buffer view;
    int held;
} Arg;

/* Get a C-contiguous buffer of `ndim` dimensions and items of `itemsize` bytes;
 * writable if asked. */
static int get(PyObject *obj, Arg *arg, int ndim, Py_ssize_t itemsize, int writable)
{
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, &arg->view, flags) < 0)
        return -1;
    arg->held = 1;
    if (arg->view.ndim != ndim || arg->view.itemsize != itemsize) {
        PyErr_Format(PyExc_ValueError, "%s: expected %d dimensions of %zd-byte items", arg->name,
                     ndim, itemsize);
        return -1;
    }
    return 0;
}

static void release(Arg *args, int n)
{
    for (int i = 0; i < n; i++)
        if (args[i].held)
            PyBuffer_Release(&args[i].view);
}

static int same_shape(const Arg *a, Py_ssize_t d0, Py_ssize_t d1)
{
    if (a->view.shape[0] != d0 || a->view.shape[1] != d1) {
        PyErr_Format(PyExc_ValueError, "%s: expected shape (%zd, %zd, ...)", a->name, d0, d1);
        return 0;
    }
    return 1;
}

/* ------------------------------------------------------------------------- */
/* Python functions                                                          */
/* ------------------------------------------------------------------------- */

PyDoc_STRVAR(splat_doc,
             "splat(flow, priority, scale, index, depth)\n\n"
             "Forward-splat source indices along scale * flow into index (-1 = hole).\n"
             "flow (H, W, 2) float32, priority (H, W) float32, index (H, W) int32,\n"
             "depth (H, W) float32 (work buffer).");

static PyObject *py_splat(PyObject *self, PyObject *args)
{
    PyObject *o[4];
    double scale;
    if (!PyArg_ParseTuple(args, "OOdOO", &o[0], &o[1], &scale, &o[2], &o[3]))
        return NULL;
    Arg a[4] = {{"flow"}, {"priority"}, {"index"}, {"depth"}};
    PyObject *result = NULL;
    if (get(o[0], &a[0], 3, 4, 0) < 0 || get(o[1], &a[1], 2, 4, 0) < 0 ||
        get(o[2], &a[2], 2, 4, 1) < 0 || get(o[3], &a[3], 2, 4, 1) < 0)
        goto done;
    const Py_ssize_t h = a[0].view.shape[0], w = a[0].view.shape[1];
    if (a[0].view.shape[2] != 2) {
        PyErr_SetString(PyExc_ValueError, "flow: expected shape (H, W, 2)");
        goto done;
    }
    if (!same_shape(&a[1], h, w) || !same_shape(&a[2], h, w) || !same_shape(&a[3], h, w))
        goto done;
    Py_BEGIN_ALLOW_THREADS
    splat(a[0].view.buf, a[1].view.buf, scale, a[2].view.buf, a[3].view.buf, h, w);
    Py_END_ALLOW_THREADS
    result = Py_NewRef(Py_None);
done:
    release(a, 4);
    return result;
}

static int fill_holes(uint8_t *out, const uint8_t *hole, Py_ssize_t h, Py_ssize_t w,
                      Py_ssize_t nc)
{
    uint8_t *empty_row = PyMem_RawCalloc((size_t)h, 1);
    if (empty_row == NULL)
        return -1;
    for (Py_ssize_t y = 0; y < h; y++)
        empty_row[y] = (uint8_t)fill_row(out, hole, y, w, nc);
    const int ok = fill_empty_rows(out, empty_row, h, w, nc);
    PyMem_RawFree(empty_row);
    return ok;
}

PyDoc_STRVAR(fill_holes_doc,
             "fill_holes(out, hole) -> bool\n\n"
             "Scanline hole filling of out (H, W, C) uint8 in place where hole (H, W) bool;\n"
             "False if there was no non-hole pixel at all.");

static PyObject *py_fill_holes(PyObject *self, PyObject *args)
{
    PyObject *o[2];
    if (!PyArg_ParseTuple(args, "OO", &o[0], &o[1]))
        return NULL;
    Arg a[2] = {{"out"}, {"hole"}};
    PyObject *result = NULL;
    if (get(o[0], &a[0], 3, 1, 1) < 0 || get(o[1], &a[1], 2, 1, 0) < 0)
        goto done;
    const Py_ssize_t h = a[0].view.shape[0], w = a[0].view.shape[1], nc = a[0].view.shape[2];
    if (!same_shape(&a[1], h, w))
        goto done;
    int ok;
    Py_BEGIN_ALLOW_THREADS
    ok = fill_holes(a[0].view.buf, a[1].view.buf, h, w, nc);
    Py_END_ALLOW_THREADS
    if (ok < 0)
        PyErr_NoMemory();
    else
        result = PyBool_FromLong(ok);
done:
    release(a, 2);
    return result;
}

static int render(const uint8_t *pixels0, const uint8_t *pixels1, const float *flow0,
                  const float *flow1, const float *priority0, const float *priority1,
                  double alpha, int hole_aware, int fill, int32_t *index0, int32_t *index1,
                  float *depth0, float *depth1, uint8_t *out, uint8_t *hole, Py_ssize_t h,
                  Py_ssize_t w, Py_ssize_t nc)
{
    splat(flow0, priority0, alpha, index0, depth0, h, w);
    splat(flow1, priority1, 1.0 - alpha, index1, depth1, h, w);
    double w0[256], w1[256];
    const double a0 = 1.0 - alpha;
    for (int v = 0; v < 256; v++) {
        w0[v] = a0 * (double)v;
        w1[v] = alpha * (double)v;
    }
    uint8_t *empty_row = PyMem_RawCalloc((size_t)h, 1);
    if (empty_row == NULL)
        return -1;
    for (Py_ssize_t y = 0; y < h; y++) {
        blend_row(pixels0, pixels1, index0, index1, w0, w1, hole_aware, out, hole, y, w, nc);
        if (fill)
            empty_row[y] = (uint8_t)fill_row(out, hole, y, w, nc);
    }
    const int ok = fill ? fill_empty_rows(out, empty_row, h, w, nc) : 1;
    PyMem_RawFree(empty_row);
    return ok;
}

PyDoc_STRVAR(render_doc,
             "render(pixels0, pixels1, flow0, flow1, priority0, priority1, alpha, hole_aware,\n"
             "       fill, index0, index1, depth0, depth1, out, hole) -> bool\n\n"
             "One morph frame before the median: both splats, then blend and fill row by\n"
             "row. pixels (H*W, C) uint8; flows (H, W, 2) float32; priorities and depths\n"
             "(H, W) float32; indices (H, W) int32; out (H, W, C) uint8; hole (H, W) bool.\n"
             "False when the fill found no pixel to fill from (out is then meaningless).");

static PyObject *py_render(PyObject *self, PyObject *args)
{
    PyObject *o[13];
    double alpha;
    int hole_aware, fill;
    if (!PyArg_ParseTuple(args, "OOOOOOdppOOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5],
                          &alpha, &hole_aware, &fill, &o[6], &o[7], &o[8], &o[9], &o[10],
                          &o[11]))
        return NULL;
    Arg a[12] = {{"pixels0"}, {"pixels1"}, {"flow0"},  {"flow1"},  {"priority0"}, {"priority1"},
                 {"index0"},  {"index1"},  {"depth0"}, {"depth1"}, {"out"},       {"hole"}};
    PyObject *result = NULL;
    if (get(o[10], &a[10], 3, 1, 1) < 0)
        goto done;
    const Py_ssize_t h = a[10].view.shape[0], w = a[10].view.shape[1], nc = a[10].view.shape[2];
    if (get(o[0], &a[0], 2, 1, 0) < 0 || get(o[1], &a[1], 2, 1, 0) < 0 ||
        get(o[2], &a[2], 3, 4, 0) < 0 || get(o[3], &a[3], 3, 4, 0) < 0 ||
        get(o[4], &a[4], 2, 4, 0) < 0 || get(o[5], &a[5], 2, 4, 0) < 0 ||
        get(o[6], &a[6], 2, 4, 1) < 0 || get(o[7], &a[7], 2, 4, 1) < 0 ||
        get(o[8], &a[8], 2, 4, 1) < 0 || get(o[9], &a[9], 2, 4, 1) < 0 ||
        get(o[11], &a[11], 2, 1, 1) < 0)
        goto done;
    if (!same_shape(&a[0], h * w, nc) || !same_shape(&a[1], h * w, nc))
        goto done;
    for (int i = 2; i < 12; i++)
        if (i != 10 && !same_shape(&a[i], h, w))
            goto done;
    if (a[2].view.shape[2] != 2 || a[3].view.shape[2] != 2) {
        PyErr_SetString(PyExc_ValueError, "flow0, flow1: expected shape (H, W, 2)");
        goto done;
    }
    int ok;
    Py_BEGIN_ALLOW_THREADS
    ok = render(a[0].view.buf, a[1].view.buf, a[2].view.buf, a[3].view.buf, a[4].view.buf,
                a[5].view.buf, alpha, hole_aware, fill, a[6].view.buf, a[7].view.buf,
                a[8].view.buf, a[9].view.buf, a[10].view.buf, a[11].view.buf, h, w, nc);
    Py_END_ALLOW_THREADS
    if (ok < 0)
        PyErr_NoMemory();
    else
        result = PyBool_FromLong(ok);
done:
    release(a, 12);
    return result;
}

static PyMethodDef methods[] = {
    {"splat", py_splat, METH_VARARGS, splat_doc},
    {"fill_holes", py_fill_holes, METH_VARARGS, fill_holes_doc},
    {"render", py_render, METH_VARARGS, render_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT,
    "miketalk._morph_kernels",
    "The morph's per-pixel kernels in C (see miketalk.morph).",
    -1,
    methods,
};

PyMODINIT_FUNC PyInit__morph_kernels(void) { return PyModule_Create(&module); }
