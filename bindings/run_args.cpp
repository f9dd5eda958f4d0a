// The options and record arrays of a run (run_args.hpp).
#include "run_args.hpp"

#include <string>

namespace bind {

core::sim::Options options_of(nb::handle opt) {
    core::sim::Options o;
    if (nb::isinstance<nb::tuple>(opt)) {
        nb::tuple t = nb::borrow<nb::tuple>(opt);
        require(t.size() == 12 || t.size() == 13, "options: the 12 fields of Options (and the deadline)");
        o.nc = nb::cast<int>(t[0]), o.nvel = nb::cast<int>(t[1]), o.ne = nb::cast<int>(t[2]);
        o.max_steps = nb::cast<int64_t>(t[3]), o.nsteps = nb::cast<int64_t>(t[4]);
        o.dt = nb::cast<double>(t[5]), o.rtol = nb::cast<double>(t[6]), o.atol = nb::cast<double>(t[7]);
        o.h0 = nb::cast<double>(t[8]), o.hmax = nb::cast<double>(t[9]), o.blowup = nb::cast<double>(t[10]);
        const int probe = PyObject_IsTrue(t[11].ptr());
        if (probe < 0) throw nb::python_error();
        o.probe = probe != 0;
        if (t.size() == 13) o.deadline = nb::cast<double>(t[12]);
        return o;
    }
    nb::dict d;
    if (!nb::try_cast(opt, d)) throw nb::type_error("options: a tuple of Options' fields or a dict of them");
    o.nc = nb::cast<int>(d["nc"]), o.nvel = nb::cast<int>(d["nvel"]), o.ne = nb::cast<int>(d["ne"]);
    o.max_steps = nb::cast<int64_t>(d["max_steps"]), o.nsteps = nb::cast<int64_t>(d["nsteps"]);
    o.dt = nb::cast<double>(d["dt"]), o.rtol = nb::cast<double>(d["rtol"]);
    o.atol = nb::cast<double>(d["atol"]), o.h0 = nb::cast<double>(d["h0"]);
    o.hmax = nb::cast<double>(d["hmax"]), o.blowup = nb::cast<double>(d["blowup"]);
    o.probe = nb::cast<bool>(d["probe"]);
    if (d.contains("deadline")) o.deadline = nb::cast<double>(d["deadline"]);
    return o;
}

struct RecordBuffer {
    Py_buffer view;
};

void RecordBufferRelease::operator()(RecordBuffer* b) const {
    PyBuffer_Release(&b->view);
    delete b;
}

std::pair<RecordHold, uint8_t*> record_of(nb::handle x, size_t size, const char* name) {
    const std::string what = std::string(name) + ": a record array of the right dtype";
    // (only numpy's arrays: a bytearray or a memoryview of the right length is no record array)
    if (!nb::hasattr(x, "dtype")) throw nb::type_error(what.c_str());
    auto* b = new RecordBuffer;
    if (PyObject_GetBuffer(x.ptr(), &b->view, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS) != 0) {
        delete b;
        PyErr_Clear();
        throw nb::type_error(what.c_str());
    }
    RecordHold hold(b);
    if (b->view.len < static_cast<Py_ssize_t>(size)) throw nb::type_error(what.c_str());
    return {std::move(hold), static_cast<uint8_t*>(b->view.buf)};
}

}  // namespace bind
