// The options and record arrays of a run (run_args.hpp).
#include "run_args.hpp"

#include <string>

namespace bind {

core::sim::Options options_of(const nb::dict& opt) {
    core::sim::Options o;
    o.nc = nb::cast<int>(opt["nc"]), o.nvel = nb::cast<int>(opt["nvel"]), o.ne = nb::cast<int>(opt["ne"]);
    o.max_steps = nb::cast<int64_t>(opt["max_steps"]), o.nsteps = nb::cast<int64_t>(opt["nsteps"]);
    o.dt = nb::cast<double>(opt["dt"]), o.rtol = nb::cast<double>(opt["rtol"]);
    o.atol = nb::cast<double>(opt["atol"]), o.h0 = nb::cast<double>(opt["h0"]);
    o.hmax = nb::cast<double>(opt["hmax"]), o.blowup = nb::cast<double>(opt["blowup"]);
    o.probe = nb::cast<bool>(opt["probe"]);
    if (opt.contains("deadline")) o.deadline = nb::cast<double>(opt["deadline"]);
    return o;
}

std::pair<nb::object, uint8_t*> record_of(nb::handle x, size_t size, const char* name) {
    nb::object raw = x.attr("view")(nb::module_::import_("numpy").attr("uint8"));
    nb::ndarray<uint8_t, nb::ndim<1>, nb::c_contig, nb::device::cpu> a;
    if (!nb::try_cast(raw, a, false) || a.shape(0) < size)
        throw nb::type_error((std::string(name) + ": a record array of the right dtype").c_str());
    return {raw, a.data()};
}

}  // namespace bind
