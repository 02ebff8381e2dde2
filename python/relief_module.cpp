// SPDX-License-Identifier: Apache-2.0
// relief._relief: the Python module's native part (pybind11). The package's
// __init__.py makes one Python function per entry of the operation table;
// they all come here, to run(), which parses the keywords with the table's
// parser and runs the operation as the command line does.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <OpenImageIO/imagebuf.h>

#include <chrono>
#include <cstring>
#include <optional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "relief/relief.h"

namespace py = pybind11;
using OIIO::ImageBuf;
using OIIO::TypeDesc;

namespace {

// numpy dtype -> the pixel type the command line would read from a file.
TypeDesc pixel_type(const py::array& a)
{
    const py::dtype d = a.dtype();
    if (d.kind() == 'u' && d.itemsize() == 1)
        return TypeDesc::UINT8;
    if (d.kind() == 'u' && d.itemsize() == 2)
        return TypeDesc::UINT16;
    if (d.kind() == 'f' && d.itemsize() == 2)
        return TypeDesc::HALF;
    if (d.kind() == 'f' && d.itemsize() == 4)
        return TypeDesc::FLOAT;
    throw py::value_error("relief: pixels must be uint8, uint16, float16 or float32, not " +
                          py::cast<std::string>(py::str(static_cast<const py::handle&>(d))));
}

// A metadata value as Python has it: one integer or one number as such,
// anything else (text, arrays, matrices) as its text.
py::object typed_value(const OIIO::ParamValue& p)
{
    const TypeDesc t = p.type();
    if (p.nvalues() == 1 && t.aggregate == TypeDesc::SCALAR && t.arraylen == 0) {
        if (t.basetype == TypeDesc::INT || t.basetype == TypeDesc::UINT || t.basetype == TypeDesc::INT16 ||
            t.basetype == TypeDesc::UINT16 || t.basetype == TypeDesc::INT8 || t.basetype == TypeDesc::UINT8)
            return py::int_(p.get_int());
        if (t.basetype == TypeDesc::FLOAT || t.basetype == TypeDesc::HALF || t.basetype == TypeDesc::DOUBLE)
            return py::float_(p.get_float());
    }
    return py::str(p.get_string());
}

// key = value on `spec` in the value's type: int, float or text (bool as int).
void set_attribute(OIIO::ImageSpec& spec, const std::string& key, const py::handle& value)
{
    if (py::isinstance<py::bool_>(value) || py::isinstance<py::int_>(value))
        spec.attribute(key, int(value.cast<long long>()));
    else if (py::isinstance<py::float_>(value))
        spec.attribute(key, value.cast<float>());
    else
        spec.attribute(key, std::string(py::str(value)));
}

// H x W or H x W x C, any strides -> an ImageBuf in the array's own type
// (copied, so no numpy memory is touched once the GIL is released).
ImageBuf to_imagebuf(const py::array& input, const relief::ImageSlot& slot, const std::string& op,
                     const py::dict& metadata)
{
    const TypeDesc type = pixel_type(input);
    const std::string what = op + ": input '" + slot.name + "'";
    if (input.ndim() != 2 && input.ndim() != 3)
        throw py::value_error(what + " must be H x W or H x W x C, not " + std::to_string(input.ndim()) +
                              "-dimensional");
    // The shape is checked before anything is copied: a broadcast array
    // can claim more pixels than the machine holds.
    const long long h = input.shape(0), w = input.shape(1), c = input.ndim() == 3 ? input.shape(2) : 1;
    const std::string problem = relief::input_problem(op, slot, w, h, c, int(type.size()));
    if (!problem.empty())
        throw py::value_error(problem);
    // One copy, into the image, whatever the array's strides, as long as a
    // pixel's channels lie side by side (any C-contiguous array, a view of
    // rows or columns, a broadcast); otherwise numpy's C-ordered copy
    // first.
    ImageBuf buf(OIIO::ImageSpec(int(w), int(h), int(c), type));
    const py::ssize_t item = input.itemsize();
    const bool channels_packed = input.ndim() == 2 || c == 1 || input.strides(2) == item;
    if (channels_packed) {
        const OIIO::stride_t xstride = input.strides(1), ystride = input.strides(0);
        if (!buf.set_pixels(buf.roi(), type, input.data(), xstride, ystride))
            throw std::runtime_error(what + ": " + buf.geterror());
    } else {
        const py::array a = py::array::ensure(input, py::array::c_style);
        if (!a)  // numpy could not make the copy (its MemoryError is set)
            throw py::error_already_set();
        if (!buf.set_pixels(buf.roi(), type, a.data()))
            throw std::runtime_error(what + ": " + buf.geterror());
    }
    for (const auto& [key, value] : metadata)
        set_attribute(buf.specmod(), py::str(key), value);
    return buf;
}

py::array_t<float> to_numpy(const ImageBuf& img)
{
    const OIIO::ImageSpec& s = img.spec();
    py::array_t<float> out({py::ssize_t(s.height), py::ssize_t(s.width), py::ssize_t(s.nchannels)});
    if (!img.get_pixels(img.roi(), TypeDesc::FLOAT, out.mutable_data()))
        throw std::runtime_error("relief: cannot read the result: " + img.geterror());
    return out;
}

std::map<std::string, py::object> metadata_of(const ImageBuf& img)
{
    std::map<std::string, py::object> m;
    for (const auto& p : img.spec().extra_attribs)
        if (p.name().string().rfind("relief:", 0) == 0)
            m[p.name().string()] = typed_value(p);
    return m;
}

relief::OperationCall parse_call(const std::string& op,
                                 const std::vector<std::pair<std::string, std::string>>& modifiers)
{
    relief::OperationCall call;
    if (!relief::parse_modifiers(call, op, modifiers))
        throw py::value_error(relief::find_operation(op) ? op + ": " + relief::geterror()
                                                         : relief::geterror());
    return call;
}

// The arrays as images of the operation's input slots (slot i of `slots`,
// or slot 0 for every array when `one_slot`).
std::vector<ImageBuf> to_imagebufs(const std::string& op, const std::vector<py::array>& arrays,
                                   const std::vector<py::dict>& metadata, bool one_slot)
{
    const relief::OperationInfo& info = *relief::find_operation(op);
    std::vector<ImageBuf> bufs;
    for (std::size_t i = 0; i < arrays.size(); ++i)
        bufs.push_back(to_imagebuf(arrays[i], info.inputs[one_slot ? 0 : i], op,
                                   i < metadata.size() ? metadata[i] : py::dict()));
    return bufs;
}

// Before any array is copied: each array's shape and the memory its copy
// needs (ValueError), then the
// operation's memory estimate for its size on `device` (RuntimeError, as
// the run itself would refuse it), so a map too large is refused at once.
void check_before_copy(const relief::OperationCall& call, const std::string& device,
                       const std::vector<py::array>& arrays, bool one_slot)
{
    const relief::OperationInfo& info = *relief::find_operation(call.operation);
    for (std::size_t i = 0; i < arrays.size(); ++i) {
        const py::array& a = arrays[i];
        if (a.ndim() != 2 && a.ndim() != 3)
            continue;  // (to_imagebuf says why)
        const long long h = a.shape(0), w = a.shape(1), c = a.ndim() == 3 ? a.shape(2) : 1;
        if (const std::string why = relief::input_problem(call.operation, info.inputs[one_slot ? 0 : i], w, h,
                                                          c, int(pixel_type(a).size()));
            !why.empty())
            throw py::value_error(why);
        if (const std::string why = relief::memory_problem(call, device, w, h); !why.empty())
            throw std::runtime_error(why);
    }
}

std::vector<const ImageBuf*> pointers(const std::vector<ImageBuf>& bufs)
{
    std::vector<const ImageBuf*> p;
    for (const ImageBuf& b : bufs)
        p.push_back(&b);
    return p;
}

// A running operation's link to Python. Messages and progress reach their
// callables with the GIL taken; a callable that raises, a progress answer
// that is true, or Ctrl-C (a pending signal, looked for at most every
// 50 ms before a kernel) cancels the operation at its next kernel, and
// raise_if_stopped() then raises what stopped it.
class PythonCallbacks {
public:
    PythonCallbacks(py::object messages, py::object progress)
        : messages_(std::move(messages)), progress_(std::move(progress))
    {
    }

    relief::Execution execution(const std::string& device)
    {
        relief::Execution exec;
        exec.device = device;
        if (!messages_.is_none())
            exec.on_message = [this](relief::Severity s, const std::string& text) {
                call([&] { messages_(severity_name(s), text); });
            };
        if (!progress_.is_none())
            exec.on_progress = [this](double fraction) {
                call([&] {
                    if (py::bool_(progress_(fraction)))
                        asked_ = true;
                });
            };
        exec.cancel = [this] {
            const auto now = std::chrono::steady_clock::now();
            if (!stop_ && now - signals_looked_at_ > std::chrono::milliseconds(50)) {
                signals_looked_at_ = now;
                py::gil_scoped_acquire gil;
                if (PyErr_CheckSignals() != 0)
                    keep(py::error_already_set());
            }
            return stop_ || asked_;
        };
        return exec;
    }

    // With the GIL: what stopped the operation, raised; else its failure
    // as RuntimeError (`error`), if it failed.
    void raise_if_stopped(bool ok, const std::string& error)
    {
        if (raised_)
            throw std::move(*raised_);
        if (!ok && asked_)
            throw Cancelled(error);
        if (!ok)
            throw std::runtime_error(error);
    }

    // relief.CancelledError: the progress callable asked to stop.
    struct Cancelled : std::runtime_error {
        using std::runtime_error::runtime_error;
    };

private:
    static const char* severity_name(relief::Severity s)
    {
        switch (s) {
        case relief::Severity::Debug: return "debug";
        case relief::Severity::Info: return "info";
        case relief::Severity::Notice: return "notice";
        case relief::Severity::Warning: return "warning";
        }
        return "info";
    }
    template <class Body>
    void call(Body body)
    {
        if (stop_)
            return;
        py::gil_scoped_acquire gil;
        try {
            body();
        } catch (py::error_already_set& e) {
            keep(std::move(e));
        }
    }
    void keep(py::error_already_set&& e)
    {
        raised_.emplace(std::move(e));
        stop_ = true;
    }

    py::object messages_, progress_;
    std::optional<py::error_already_set> raised_;
    bool stop_ = false, asked_ = false;
    std::chrono::steady_clock::time_point signals_looked_at_{};
};

// One operation: inputs (arrays and their metadata), modifiers as text ->
// (float32 array H x W x C, metadata).
py::tuple run(const std::string& op, const std::vector<py::array>& arrays,
              const std::vector<py::dict>& metadata,
              const std::vector<std::pair<std::string, std::string>>& modifiers, const std::string& device,
              py::object messages, py::object progress)
{
    const relief::OperationCall call = parse_call(op, modifiers);
    if (const std::string why = relief::call_problem(op, arrays.size()); !why.empty())
        throw py::value_error(why);
    check_before_copy(call, device, arrays, false);
    const std::vector<ImageBuf> bufs = to_imagebufs(op, arrays, metadata, false);
    PythonCallbacks callbacks(std::move(messages), std::move(progress));
    const relief::Execution exec = callbacks.execution(device);
    ImageBuf out;
    bool ok;
    std::string error;
    {
        py::gil_scoped_release device_work;
        ok = relief::run_operation(out, call, pointers(bufs), exec);
        if (!ok)
            error = relief::geterror();
    }
    callbacks.raise_if_stopped(ok, error);
    return py::make_tuple(to_numpy(out), metadata_of(out));
}

// One operation over the tiles of a UDIM set at once (relief/udim.h):
// tile numbers and one array each -> a list of (array, metadata), in order.
py::list run_tiles(const std::string& op, const std::vector<int>& numbers,
                   const std::vector<py::array>& arrays, const std::vector<py::dict>& metadata,
                   const std::vector<std::pair<std::string, std::string>>& modifiers,
                   const std::string& device, py::object messages, py::object progress)
{
    const relief::OperationCall call = parse_call(op, modifiers);
    if (const std::string why = relief::tiles_call_problem(op, numbers, arrays.size()); !why.empty())
        throw py::value_error(why);
    check_before_copy(call, device, arrays, true);
    const std::vector<ImageBuf> bufs = to_imagebufs(op, arrays, metadata, true);
    PythonCallbacks callbacks(std::move(messages), std::move(progress));
    const relief::Execution exec = callbacks.execution(device);
    std::vector<ImageBuf> out;
    bool ok;
    std::string error;
    {
        py::gil_scoped_release device_work;
        ok = relief::run_operation_on_tiles(out, call, numbers, pointers(bufs), exec);
        if (!ok)
            error = relief::geterror();
    }
    callbacks.raise_if_stopped(ok, error);
    py::list results;
    for (const ImageBuf& img : out)
        results.append(py::make_tuple(to_numpy(img), metadata_of(img)));
    return results;
}

// The file's pixels in its own type (uint8, uint16, float16, float32; other
// types as float32), so that an operation on them decodes what the command
// line would decode from the same file.
py::tuple read_file(const std::string& path)
{
    ImageBuf img;
    bool ok;
    {
        py::gil_scoped_release io;
        ok = relief::read_image(img, path);
    }
    if (!ok)
        throw std::runtime_error(relief::geterror());
    TypeDesc t = img.nativespec().format;
    if (t != TypeDesc::UINT8 && t != TypeDesc::UINT16 && t != TypeDesc::HALF)
        t = TypeDesc::FLOAT;
    const OIIO::ImageSpec& s = img.spec();
    const std::string dtype = t == TypeDesc::UINT8    ? "uint8"
                              : t == TypeDesc::UINT16 ? "uint16"
                              : t == TypeDesc::HALF   ? "float16"
                                                      : "float32";
    py::array out(py::dtype(dtype), {py::ssize_t(s.height), py::ssize_t(s.width), py::ssize_t(s.nchannels)});
    if (!img.get_pixels(img.roi(), t, out.mutable_data()))
        throw std::runtime_error(path + ": " + img.geterror());
    std::map<std::string, py::object> meta;
    for (const auto& p : s.extra_attribs)
        meta[p.name().string()] = typed_value(p);
    return py::make_tuple(out, meta);
}

void write_file(const std::string& path, const py::array& input, const py::dict& metadata,
                const std::string& type, const std::string& compression)
{
    relief::ImageSlot any{"image", 1, 4096, ""};
    const ImageBuf img = to_imagebuf(input, any, "write", metadata);
    relief::WriteOptions w;
    if (type == "float" || type == "half" || type == "uint16" || type == "uint8")
        w.format = TypeDesc(type);
    else
        throw py::value_error("write: type=" + type + " is not one of float|half|uint16|uint8");
    w.compression = compression;
    bool ok;
    {
        py::gil_scoped_release io;
        ok = relief::check_output_path(path) && relief::write_image(img, path, w);
    }
    if (!ok)
        throw std::runtime_error(relief::geterror());
}

}  // namespace

PYBIND11_MODULE(_relief, m)
{
    m.doc() = "relief's native module; use the relief package";
    m.attr("version") = relief::version();
    m.def("operations_json", &relief::operations_json);
    m.def("run", &run, py::arg("operation"), py::arg("arrays"), py::arg("metadata"), py::arg("modifiers"),
          py::arg("device") = "auto", py::arg("messages") = py::none(), py::arg("progress") = py::none());
    py::register_exception<PythonCallbacks::Cancelled>(m, "CancelledError", PyExc_RuntimeError);
    m.def("run_tiles", &run_tiles, py::arg("operation"), py::arg("numbers"), py::arg("arrays"),
          py::arg("metadata"), py::arg("modifiers"), py::arg("device") = "auto",
          py::arg("messages") = py::none(), py::arg("progress") = py::none());
    m.def("read", &read_file, py::arg("path"));
    m.def("write", &write_file, py::arg("path"), py::arg("array"), py::arg("metadata"),
          py::arg("type") = "float", py::arg("compression") = "");
    m.def("prepare", &relief::prepare, py::arg("device"), py::arg("width"), py::arg("height"),
          py::call_guard<py::gil_scoped_release>());
}
