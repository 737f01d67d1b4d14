/* The per-physics-step arithmetic of the framework in C: an optional speed-up.

   Two types, each the exact twin of a pure-Python path (the fallback when this module is
   not built; tests hold both to the same results, bit for bit):

   * FtNoise    - world/realism.py `WristForceNoise.offset`: the wrist sensor's white noise
                  and random-walk bias drift, a function of the physics step read at.
   * WristForce - engine/context.py `Context.wrist_force_norm_sq` and
                  `true_wrist_force_norm_sq`: the raw sensor reading rotated into the world
                  frame, the hand's weight and the sensor's bias removed, noise added,
                  one reading per simulated instant (world/step_clock.py `StepClock.t`).

   The guards' envelope test has no twin here: measured, it made no difference a run could see
   (bench/guards_envelope.py), so guards/bank.py's Python is its one definition.

   The arithmetic is written in the order Python evaluates it and compiled without
   floating-point contraction (-ffp-contract=off): no fused multiply-add, so every result
   rounds as Python's float operations do. Views are read through the addresses of numpy
   arrays that the Python side keeps alive (MjData's arrays never move). */

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

/* ---------------------------------------------------------------- FtNoise ---------- */

typedef struct {
    PyObject_HEAD
    double std, drift, dt; /* [N], [N/sqrt(s)], the physics timestep [s] */
    double bias[3];
    double k;          /* the physics step the bias has walked to (0: none drawn yet) */
    double tau;        /* simulated time of step k, summed as the step function sums it [s] */
    double t;          /* simulated time of the last reading [s] (NaN: none yet) */
    double offset[3];  /* what noise and drift added to that reading [N] */
    PyObject *refill;  /* () -> float64 array of 6 * block normal samples */
    PyObject *block;   /* the samples drawn ahead (kept alive) */
    const double *draws;
    Py_ssize_t next, n; /* next reading's index, readings in the block */
} FtNoise;

static int ftnoise_refill(FtNoise *self) {
    if (self->refill == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "FtNoise is not initialised (or was cleared)");
        return -1;
    }
    PyObject *arr = PyObject_CallNoArgs(self->refill);
    if (arr == NULL) return -1;
    Py_buffer view;
    if (PyObject_GetBuffer(arr, &view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) {
        Py_DECREF(arr);
        return -1;
    }
    if (view.itemsize != 8 || view.format == NULL || strcmp(view.format, "d") != 0 ||
        view.len < 48) {
        PyBuffer_Release(&view);
        Py_DECREF(arr);
        PyErr_SetString(PyExc_ValueError, "FtNoise refill must return float64 samples, 6 a step");
        return -1;
    }
    self->draws = (const double *)view.buf;
    self->n = view.len / 48;
    PyBuffer_Release(&view); /* the array is kept: its memory stays */
    Py_XSETREF(self->block, arr);
    self->next = 0;
    return 0;
}

/* `WristForceNoise.offset(t)`, written as its Python is evaluated. */
static int ftnoise_offset(FtNoise *self, double t, double out[3]) {
    if (t != self->t) {
        self->t = t;
        double k = floor(t / self->dt + 0.5);
        if (!(k >= 1.0)) k = 1.0;
        const double *n = NULL;
        double *b = self->bias;
        for (; self->k < k; self->k += 1.0) {
            if (self->next == self->n && ftnoise_refill(self) < 0) return -1;
            n = self->draws + 6 * self->next;
            self->next += 1;
            double tau = self->tau + self->dt;
            double walk = self->drift * sqrt(self->k != 0.0 ? tau - self->tau : 0.0);
            b[0] = b[0] + walk * n[3];
            b[1] = b[1] + walk * n[4];
            b[2] = b[2] + walk * n[5];
            self->tau = tau;
        }
        if (n != NULL) {
            double s = self->std;
            self->offset[0] = b[0] + s * n[0];
            self->offset[1] = b[1] + s * n[1];
            self->offset[2] = b[2] + s * n[2];
        }
    }
    memcpy(out, self->offset, sizeof self->offset);
    return 0;
}

static int ftnoise_init(FtNoise *self, PyObject *args, PyObject *kwds) {
    static char *kw[] = {"std_n", "drift_n_per_sqrt_s", "dt", "refill", NULL};
    PyObject *refill;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "dddO", kw, &self->std, &self->drift,
                                     &self->dt, &refill))
        return -1;
    if (!(self->dt > 0.0)) {
        PyErr_SetString(PyExc_ValueError, "dt must be > 0");
        return -1;
    }
    if (!PyCallable_Check(refill)) {
        PyErr_SetString(PyExc_TypeError, "refill must be callable");
        return -1;
    }
    Py_INCREF(refill);
    Py_XSETREF(self->refill, refill);
    Py_CLEAR(self->block);
    self->bias[0] = self->bias[1] = self->bias[2] = 0.0;
    self->offset[0] = self->offset[1] = self->offset[2] = 0.0;
    self->k = self->tau = 0.0;
    self->t = NAN;
    self->draws = NULL;
    self->next = self->n = 0;
    return 0;
}

/* Garbage-collector support: `refill` is a bound method or closure of the Python object that
   owns this one (WristForceNoise), a reference cycle only the collector can free. */
static int ftnoise_traverse(FtNoise *self, visitproc visit, void *arg) {
    Py_VISIT(self->refill);
    Py_VISIT(self->block);
    return 0;
}

static int ftnoise_clear(FtNoise *self) {
    Py_CLEAR(self->refill); /* the block stays: `draws` points into it */
    return 0;
}

static void ftnoise_dealloc(FtNoise *self) {
    PyObject_GC_UnTrack(self);
    Py_XDECREF(self->refill);
    Py_XDECREF(self->block);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyObject *ftnoise_offset_py(FtNoise *self, PyObject *arg) {
    double t = PyFloat_AsDouble(arg);
    if (t == -1.0 && PyErr_Occurred()) return NULL;
    double o[3];
    if (ftnoise_offset(self, t, o) < 0) return NULL;
    return Py_BuildValue("(ddd)", o[0], o[1], o[2]);
}

static PyObject *ftnoise_get_bias(FtNoise *self, void *closure) {
    return Py_BuildValue("[ddd]", self->bias[0], self->bias[1], self->bias[2]);
}

/* Snapshots (engine/snapshot): the stream's position travels with the object. `__reduce__`
   gives the constructor's arguments and a state of plain values (the drift walked, the step
   it is at and that step's time, the last reading's time and offset, the block drawn ahead
   and the next step's index in it);
   `__setstate__` puts them back. */
static PyObject *ftnoise_reduce(FtNoise *self, PyObject *unused) {
    if (self->refill == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "FtNoise is not initialised (or was cleared)");
        return NULL;
    }
    PyObject *block = self->block != NULL ? self->block : Py_None;
    return Py_BuildValue("O(dddO)((ddd)ddd(ddd)On)", (PyObject *)Py_TYPE(self), self->std,
                         self->drift, self->dt, self->refill, self->bias[0], self->bias[1],
                         self->bias[2], self->k, self->tau, self->t, self->offset[0],
                         self->offset[1], self->offset[2], block, self->next);
}

static PyObject *ftnoise_setstate(FtNoise *self, PyObject *state) {
    double bias[3], k, tau, t, offset[3];
    PyObject *block;
    Py_ssize_t next;
    if (!PyArg_ParseTuple(state, "(ddd)ddd(ddd)On", &bias[0], &bias[1], &bias[2], &k, &tau, &t,
                          &offset[0], &offset[1], &offset[2], &block, &next))
        return NULL;
    const double *draws = NULL;
    Py_ssize_t n = 0;
    if (block != Py_None) {
        Py_buffer view;
        if (PyObject_GetBuffer(block, &view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) return NULL;
        int ok = view.itemsize == 8 && view.format != NULL && strcmp(view.format, "d") == 0 &&
                 view.len >= 48;
        draws = (const double *)view.buf;
        n = view.len / 48;
        PyBuffer_Release(&view); /* the array is kept below: its memory stays */
        if (!ok) {
            PyErr_SetString(PyExc_ValueError, "FtNoise block must be float64, 6 a step");
            return NULL;
        }
    }
    if (next < 0 || next > n) {
        PyErr_SetString(PyExc_ValueError, "FtNoise state: next step outside the block");
        return NULL;
    }
    Py_XSETREF(self->block, block == Py_None ? NULL : Py_NewRef(block));
    memcpy(self->bias, bias, sizeof bias);
    memcpy(self->offset, offset, sizeof offset);
    self->k = k;
    self->tau = tau;
    self->t = t;
    self->draws = draws;
    self->n = n;
    self->next = next;
    Py_RETURN_NONE;
}

static PyMethodDef ftnoise_methods[] = {
    {"offset", (PyCFunction)ftnoise_offset_py, METH_O,
     "What noise and drift add to a reading at simulated time t [s], per axis [N]."},
    {"__reduce__", (PyCFunction)ftnoise_reduce, METH_NOARGS, "For pickle: the whole stream."},
    {"__setstate__", (PyCFunction)ftnoise_setstate, METH_O, "For pickle: the stream's position."},
    {NULL}};

static PyGetSetDef ftnoise_getset[] = {
    {"bias", (getter)ftnoise_get_bias, NULL, "The drift the bias has walked to [N].", NULL},
    {NULL}};

static PyTypeObject FtNoiseType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "orchestrator.world._native.FtNoise",
    .tp_basicsize = sizeof(FtNoise),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_traverse = (traverseproc)ftnoise_traverse,
    .tp_clear = (inquiry)ftnoise_clear,
    .tp_free = PyObject_GC_Del,
    .tp_doc = "FtNoise(std_n, drift_n_per_sqrt_s, dt, refill): WristForceNoise's stream in C.",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)ftnoise_init,
    .tp_dealloc = (destructor)ftnoise_dealloc,
    .tp_methods = ftnoise_methods,
    .tp_getset = ftnoise_getset,
};

/* ---------------------------------------------------------------- WristForce ------- */

static int address_of(PyObject *array, Py_ssize_t min_len, double **out) {
    /* a float64 array's first element, through its buffer (the caller keeps the array) */
    Py_buffer view;
    if (PyObject_GetBuffer(array, &view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) return -1;
    int ok = view.itemsize == 8 && view.format != NULL && strcmp(view.format, "d") == 0 &&
             view.len >= 8 * min_len;
    *out = (double *)view.buf;
    PyBuffer_Release(&view);
    if (!ok) {
        PyErr_Format(PyExc_ValueError, "expected a contiguous float64 array of >= %zd values",
                     min_len);
        return -1;
    }
    return 0;
}

typedef struct {
    PyObject_HEAD
    PyObject *clock;     /* the world's StepClock: its `t` [s] keys the readings */
    PyObject *keep;      /* the arrays read below */
    const double *f_site; /* raw force in the sensor's site frame, shape (3,) */
    const double *rot;   /* the site's rotation, row-major 3x3 */
    double bias[3];      /* world.wrist_bias_world */
    double weight[3];    /* world.wrist_weight_world (the true weight of hand and tool) */
    FtNoise *noise;      /* NULL: no noise */
    PyObject *fallback;  /* while a sensor fault is in effect: () -> norm_sq, in Python */
    double sensed_t, sensed[3];
    double norm_t, norm;
} WristForce;

static PyObject *t_str;

/* 0 if `__init__` ran (the views are set), else -1 with an exception. */
static int wf_ready(WristForce *self) {
    if (self->clock == NULL || self->f_site == NULL || self->rot == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "WristForce is not initialised");
        return -1;
    }
    return 0;
}

static int wf_now(WristForce *self, double *now) {
    if (wf_ready(self) < 0) return -1;
    PyObject *t = PyObject_GetAttr(self->clock, t_str);
    if (t == NULL) return -1;
    *now = PyFloat_AsDouble(t);
    Py_DECREF(t);
    return (*now == -1.0 && PyErr_Occurred()) ? -1 : 0;
}

static const double *wf_sensed(WristForce *self, double now) {
    if (now != self->sensed_t) {
        const double *f = self->f_site, *r = self->rot;
        self->sensed[0] = r[0] * f[0] + r[1] * f[1] + r[2] * f[2];
        self->sensed[1] = r[3] * f[0] + r[4] * f[1] + r[5] * f[2];
        self->sensed[2] = r[6] * f[0] + r[7] * f[1] + r[8] * f[2];
        self->sensed_t = now;
    }
    return self->sensed;
}

/* The measured force before a sensor fault acts: bias - sensed + noise. */
static int wf_measured(WristForce *self, double now, double f[3]) {
    const double *r = wf_sensed(self, now);
    f[0] = self->bias[0] - r[0];
    f[1] = self->bias[1] - r[1];
    f[2] = self->bias[2] - r[2];
    if (self->noise != NULL) {
        double o[3];
        if (ftnoise_offset(self->noise, now, o) < 0) return -1;
        f[0] = f[0] + o[0];
        f[1] = f[1] + o[1];
        f[2] = f[2] + o[2];
    }
    return 0;
}

/* `Context.wrist_force_norm_sq` at `now`; -1 on an error (a norm is never negative). */
static double wf_norm_sq(WristForce *self, double now) {
    if (now == self->norm_t) return self->norm;
    double n;
    if (self->fallback != NULL) {
        PyObject *v = PyObject_CallNoArgs(self->fallback);
        if (v == NULL) return -1.0;
        n = PyFloat_AsDouble(v);
        Py_DECREF(v);
        if (n == -1.0 && PyErr_Occurred()) return -1.0;
    } else {
        double f[3];
        if (wf_measured(self, now, f) < 0) return -1.0;
        n = f[0] * f[0] + f[1] * f[1] + f[2] * f[2];
    }
    self->norm = n;
    self->norm_t = now;
    return n;
}

static int read3(PyObject *seq, double out[3], const char *what) {
    PyObject *fast = PySequence_Fast(seq, what);
    if (fast == NULL) return -1;
    if (PySequence_Fast_GET_SIZE(fast) != 3) {
        Py_DECREF(fast);
        PyErr_Format(PyExc_ValueError, "%s: expected 3 values", what);
        return -1;
    }
    for (int i = 0; i < 3; i++) {
        out[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(fast, i));
        if (out[i] == -1.0 && PyErr_Occurred()) {
            Py_DECREF(fast);
            return -1;
        }
    }
    Py_DECREF(fast);
    return 0;
}

static int wf_init(WristForce *self, PyObject *args, PyObject *kwds) {
    static char *kw[] = {"clock", "f_site", "rot", "bias", "weight", "noise", NULL};
    PyObject *clock, *f_site, *rot, *bias, *weight, *noise;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOOOOO", kw, &clock, &f_site, &rot, &bias,
                                     &weight, &noise))
        return -1;
    double *fp, *rp;
    if (address_of(f_site, 3, &fp) < 0 || address_of(rot, 9, &rp) < 0) return -1;
    if (read3(bias, self->bias, "bias") < 0 || read3(weight, self->weight, "weight") < 0)
        return -1;
    if (noise != Py_None && !PyObject_TypeCheck(noise, &FtNoiseType)) {
        PyErr_SetString(PyExc_TypeError, "noise must be an FtNoise or None");
        return -1;
    }
    PyObject *keep = PyTuple_Pack(2, f_site, rot);
    if (keep == NULL) return -1;
    Py_XSETREF(self->keep, keep);
    Py_XSETREF(self->clock, Py_NewRef(clock));
    Py_XSETREF(self->noise, noise == Py_None ? NULL : (FtNoise *)Py_NewRef(noise));
    Py_CLEAR(self->fallback);
    self->f_site = fp;
    self->rot = rp;
    self->sensed_t = self->norm_t = NAN;
    return 0;
}

/* Garbage-collector support: `fallback` is a bound method of the Context that owns this
   object (a reference cycle while a sensor fault is in effect), `noise` an FtNoise. */
static int wf_traverse(WristForce *self, visitproc visit, void *arg) {
    Py_VISIT(self->clock);
    Py_VISIT(self->keep);
    Py_VISIT(self->noise);
    Py_VISIT(self->fallback);
    return 0;
}

static int wf_clear(WristForce *self) {
    Py_CLEAR(self->fallback); /* `clock` and `keep` stay: read until the object goes */
    Py_CLEAR(self->noise);
    return 0;
}

static void wf_dealloc(WristForce *self) {
    PyObject_GC_UnTrack(self);
    Py_XDECREF(self->clock);
    Py_XDECREF(self->keep);
    Py_XDECREF(self->noise);
    Py_XDECREF(self->fallback);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyObject *wf_norm_sq_py(WristForce *self, PyObject *unused) {
    double now;
    if (wf_now(self, &now) < 0) return NULL;
    double n = wf_norm_sq(self, now);
    if (n < 0.0 && PyErr_Occurred()) return NULL;
    return PyFloat_FromDouble(n);
}

static PyObject *wf_true_norm_sq_py(WristForce *self, PyObject *unused) {
    double now;
    if (wf_now(self, &now) < 0) return NULL;
    const double *r = wf_sensed(self, now);
    double fx = self->weight[0] - r[0], fy = self->weight[1] - r[1], fz = self->weight[2] - r[2];
    return PyFloat_FromDouble(fx * fx + fy * fy + fz * fz);
}

static PyObject *wf_sensed_py(WristForce *self, PyObject *arg) {
    if (wf_ready(self) < 0) return NULL;
    double now = PyFloat_AsDouble(arg);
    if (now == -1.0 && PyErr_Occurred()) return NULL;
    const double *r = wf_sensed(self, now);
    return Py_BuildValue("(ddd)", r[0], r[1], r[2]);
}

static PyObject *wf_measured_py(WristForce *self, PyObject *arg) {
    if (wf_ready(self) < 0) return NULL;
    double now = PyFloat_AsDouble(arg);
    if (now == -1.0 && PyErr_Occurred()) return NULL;
    double f[3];
    if (wf_measured(self, now, f) < 0) return NULL;
    return Py_BuildValue("(ddd)", f[0], f[1], f[2]);
}

static PyObject *wf_set_bias(WristForce *self, PyObject *arg) {
    if (read3(arg, self->bias, "bias") < 0) return NULL;
    self->norm_t = NAN;
    Py_RETURN_NONE;
}

static PyObject *wf_set_fallback(WristForce *self, PyObject *arg) {
    if (arg != Py_None && !PyCallable_Check(arg)) {
        PyErr_SetString(PyExc_TypeError, "fallback must be callable or None");
        return NULL;
    }
    Py_XSETREF(self->fallback, arg == Py_None ? NULL : Py_NewRef(arg));
    self->norm_t = NAN;
    Py_RETURN_NONE;
}

static PyObject *wf_forget(WristForce *self, PyObject *unused) {
    self->norm_t = NAN;
    Py_RETURN_NONE;
}

/* Snapshots rebuild a WristForce on the restored MjData from what it was made of (world/
   native.py): its readings are cached per simulated instant only, so a rebuilt one reads the
   same. */
static PyObject *wf_get_bias(WristForce *self, void *closure) {
    return Py_BuildValue("(ddd)", self->bias[0], self->bias[1], self->bias[2]);
}

static PyObject *wf_get_weight(WristForce *self, void *closure) {
    return Py_BuildValue("(ddd)", self->weight[0], self->weight[1], self->weight[2]);
}

static PyGetSetDef wf_getset[] = {
    {"bias", (getter)wf_get_bias, NULL, "The sensor's zero offset [N].", NULL},
    {"weight", (getter)wf_get_weight, NULL, "The true weight of hand and tool [N].", NULL},
    {NULL}};

static PyMemberDef wf_members[] = {
    {"clock", T_OBJECT, offsetof(WristForce, clock), READONLY, "The StepClock read."},
    {"views", T_OBJECT, offsetof(WristForce, keep), READONLY, "(f_site, rot): the views read."},
    {"noise", T_OBJECT, offsetof(WristForce, noise), READONLY, "The FtNoise, or None."},
    {"fallback", T_OBJECT, offsetof(WristForce, fallback), READONLY,
     "The Python reading while a sensor fault acts, or None."},
    {NULL}};

static PyMethodDef wf_methods[] = {
    {"norm_sq", (PyCFunction)wf_norm_sq_py, METH_NOARGS,
     "Squared norm of the measured wrist force now [N^2] (one reading per instant)."},
    {"true_norm_sq", (PyCFunction)wf_true_norm_sq_py, METH_NOARGS,
     "Squared norm of the true external wrist force now [N^2]."},
    {"sensed", (PyCFunction)wf_sensed_py, METH_O,
     "The raw reading rotated into the world frame at time t [N]."},
    {"measured", (PyCFunction)wf_measured_py, METH_O,
     "bias - sensed + noise at time t [N] (before a sensor fault acts)."},
    {"set_bias", (PyCFunction)wf_set_bias, METH_O, "The sensor's zero offset (3 floats) [N]."},
    {"set_fallback", (PyCFunction)wf_set_fallback, METH_O,
     "While a sensor fault is in effect: the Python reading of norm_sq (None: none)."},
    {"forget", (PyCFunction)wf_forget, METH_NOARGS, "Drop the cached norm (a new reading)."},
    {NULL}};

static PyTypeObject WristForceType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "orchestrator.world._native.WristForce",
    .tp_basicsize = sizeof(WristForce),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_traverse = (traverseproc)wf_traverse,
    .tp_clear = (inquiry)wf_clear,
    .tp_free = PyObject_GC_Del,
    .tp_doc = "WristForce(clock, f_site, rot, bias, weight, noise): the wrist force in C.",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)wf_init,
    .tp_dealloc = (destructor)wf_dealloc,
    .tp_methods = wf_methods,
    .tp_members = wf_members,
    .tp_getset = wf_getset,
};

/* ---------------------------------------------------------------- module ----------- */

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "orchestrator.world._native",
    "The per-physics-step arithmetic in C (an optional speed-up; see world/native.py).", -1,
    NULL};

PyMODINIT_FUNC PyInit__native(void) {
    t_str = PyUnicode_InternFromString("t");
    if (t_str == NULL || PyType_Ready(&FtNoiseType) < 0 ||
        PyType_Ready(&WristForceType) < 0)
        return NULL;
    PyObject *m = PyModule_Create(&module);
    if (m == NULL) return NULL;
    if (PyModule_AddObjectRef(m, "FtNoise", (PyObject *)&FtNoiseType) < 0 ||
        PyModule_AddObjectRef(m, "WristForce", (PyObject *)&WristForceType) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
