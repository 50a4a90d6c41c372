// The out-of-core model writer (ModelVtiStreamWriter): a model's slabs appended to a .vti as
// they are built, in the layout VTK's writer gives (SPEC §7).
#include <fcntl.h>
#include <unistd.h>
#include <vtkCommand.h>
#include <vtkFloatArray.h>
#include <vtkNew.h>
#include <vtkSmartPointer.h>
#include <vtkUnsignedCharArray.h>
#include <vtkXMLImageDataWriter.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "udvr/io/field_io.h"
#include "udvr/io/io_detail.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_2d_io.h"
#include "udvr/io/vti_check.h"
#include "udvr/io/vtk_image.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr {
namespace fs = std::filesystem;
using namespace vtkio;

// ---- models, a slab at a time (out-of-core build) ----------------------------------------------

namespace {

/// An unnamed temporary file in `dir` (gone when closed, also after kill -9).
int unnamedTemporary(const fs::path& dir, const fs::path& forPath) {
#ifdef O_TMPFILE
    int fd = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
    if (fd >= 0) return fd;
#endif
    std::string name = (dir / ".udvr-spill-XXXXXX").string();
    fd = ::mkstemp(name.data());
    if (fd < 0)
        UDVR_FILE_FAIL("cannot write " << forPath.string() << ": a temporary file in "
                                       << dir.string() << ": " << writeErrorText(errno));
    ::unlink(name.c_str());
    return fd;
}

void writeAll(int fd, const unsigned char* data, std::size_t size, const fs::path& forPath) {
    while (size > 0) {
        const ssize_t w = ::write(fd, data, size);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0)
            UDVR_FILE_FAIL("cannot write " << forPath.string() << ": "
                                           << writeErrorText(w < 0 ? errno : ENOSPC));
        data += w;
        size -= static_cast<std::size_t>(w);
    }
}

/// `attr="value"` in the space VTK's writer reserves for it and fills in later
/// (vtkXMLWriter::ReserveAttributeSpace: ` attr=""` and 20 spaces).
std::string reservedAttribute(const char* attr, const std::string& value) {
    std::string s = std::string(" ") + attr + "=\"" + value + "\"";
    const std::size_t width = std::string(attr).size() + 4 + 20;
    if (s.size() < width) s.append(width - s.size(), ' ');
    return s;
}

/// A double as VTK's writer prints it (an ostream of precision 11).
std::string vtkDouble(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.11g", v);
    return buf;
}

}  // namespace

struct ModelVtiStreamWriter::Impl {
    struct Array {
        const char* name = "";
        int components = 1;
        const std::vector<float> ModelVolume::*member = nullptr;
        int fd = -1;
        std::vector<unsigned char> pending;     // the start of the next block
        std::vector<std::uint64_t> blockSizes;  // compressed, in order
        std::uint64_t rawBytes = 0, spillBytes = 0;
        double range[2] = {std::numeric_limits<double>::infinity(),
                           -std::numeric_limits<double>::infinity()};
    };
    fs::path path;
    Grid3 grid;
    int quantileCount = 0, gmmComponents = 0;
    std::size_t voxelsDone = 0;
    std::vector<Array> arrays;
    vtkSmartPointer<vtkXMLImageDataWriter> writer;  // the compressor and block size of the file
    std::size_t blockSize = 0;
    bool finished = false;

    ~Impl() {
        for (Array& a : arrays)
            if (a.fd >= 0) ::close(a.fd);
    }

    void compressBlock(Array& a, const unsigned char* data, std::size_t size) {
        vtkUnsignedCharArray* out = writer->GetCompressor()->Compress(data, size);
        if (out == nullptr)
            UDVR_FILE_FAIL("cannot write " << path.string() << ": compression failed");
        const auto n = static_cast<std::size_t>(out->GetNumberOfTuples());
        try {
            writeAll(a.fd, out->GetPointer(0), n, path);
        } catch (...) {
            out->Delete();
            throw;
        }
        out->Delete();
        a.blockSizes.push_back(n);
        a.spillBytes += n;
    }

    void append(Array& a, const float* values, std::size_t count) {
        const auto* bytes = reinterpret_cast<const unsigned char*>(values);
        std::size_t size = count * sizeof(float);
        a.rawBytes += size;
        if (!a.pending.empty()) {
            const std::size_t take = std::min(size, blockSize - a.pending.size());
            a.pending.insert(a.pending.end(), bytes, bytes + take);
            bytes += take;
            size -= take;
            if (a.pending.size() == blockSize) {
                compressBlock(a, a.pending.data(), blockSize);
                a.pending.clear();
            }
        }
        for (; size >= blockSize; bytes += blockSize, size -= blockSize)
            compressBlock(a, bytes, blockSize);
        a.pending.insert(a.pending.end(), bytes, bytes + size);
        // The range as the writer takes it (GetRange(-1): the values, or the tuples' L2 norm);
        // a minimum of slab minima is the minimum of the whole.
        auto wrapped = vtkSmartPointer<vtkFloatArray>::New();
        wrapped->SetNumberOfComponents(a.components);
        wrapped->SetArray(const_cast<float*>(values), static_cast<vtkIdType>(count), 1);
        const double* r = wrapped->GetRange(-1);
        a.range[0] = std::min(a.range[0], r[0]);
        a.range[1] = std::max(a.range[1], r[1]);
    }
};

ModelVtiStreamWriter::ModelVtiStreamWriter(const fs::path& path, const Grid3& grid,
                                           int quantileCount, int gmmComponents)
    : impl_(std::make_unique<Impl>()) {
    Impl& w = *impl_;
    w.path = path;
    w.grid = grid;
    w.quantileCount = quantileCount;
    w.gmmComponents = gmmComponents;
    requireWritableDirectory(path);
    silenceVtk();
    w.writer = vtkSmartPointer<vtkXMLImageDataWriter>::New();
    configureWriter(w.writer, Compression::Lz4);
    w.blockSize = static_cast<std::size_t>(w.writer->GetBlockSize());
    UDVR_CHECK(w.writer->GetCompressor() != nullptr && w.blockSize > 0);
    for (const ModelFileArray& file : kModelFileArrays) {  // writeModelVti's order
        const int c = file.floatsPerVoxel(quantileCount, gmmComponents);
        if (c == 0) continue;
        Impl::Array a;
        a.name = file.name;
        a.components = c;
        a.member = file.values;
        w.arrays.push_back(std::move(a));
    }
    fs::path dir = path.parent_path();
    if (dir.empty()) dir = ".";
    for (Impl::Array& a : w.arrays) {
        a.fd = unnamedTemporary(dir, path);
        a.pending.reserve(w.blockSize);
    }
}

ModelVtiStreamWriter::~ModelVtiStreamWriter() = default;

void ModelVtiStreamWriter::append(const ModelVolume& slab) {
    Impl& w = *impl_;
    UDVR_CHECK(!w.finished);
    const std::size_t voxels = slab.mean.size();
    UDVR_CHECK_MSG(w.voxelsDone + voxels <= w.grid.pointCount(), "model slabs beyond the grid");
    for (Impl::Array& a : w.arrays) {
        const std::vector<float>& values = slab.*(a.member);
        UDVR_CHECK_MSG(values.size() == voxels * static_cast<std::size_t>(a.components),
                       std::string("model slab array size: ") + a.name);
        w.append(a, values.data(), values.size());
    }
    w.voxelsDone += voxels;
}

void ModelVtiStreamWriter::finish(const ModelVolume& model) {
    Impl& w = *impl_;
    UDVR_CHECK(!w.finished);
    UDVR_CHECK_MSG(w.voxelsDone == w.grid.pointCount(), "model slabs do not cover the grid");
    w.finished = true;
    for (Impl::Array& a : w.arrays) {
        if (!a.pending.empty()) w.compressBlock(a, a.pending.data(), a.pending.size());
        a.pending.clear();
        a.pending.shrink_to_fit();
    }
    // The file as VTK writes it without point data: the header, the field data and their
    // appended bytes. The point arrays' lines and data are put in as VTK would have.
    auto image = makeImage(w.grid);
    addModelFieldData(image->GetFieldData(), model, w.quantileCount > 0, w.gmmComponents > 0);
    w.writer->SetInputData(image);
    w.writer->WriteToOutputStringOn();
    vtkNew<ErrorCollector> errors;
    w.writer->AddObserver(vtkCommand::ErrorEvent, errors);
    if (w.writer->Write() != 1 || errors->count > 0)
        UDVR_FILE_FAIL("cannot write " << w.path.string() << ": " << errors->message);
    const std::string skeleton = w.writer->GetOutputString();
    const std::string pdOpen = "<PointData>\n", pdClose = "</PointData>\n";
    const std::string appended = "<AppendedData encoding=\"raw\">\n   _";
    const std::string trailer = "\n  </AppendedData>\n</VTKFile>\n";
    const std::size_t p0 = skeleton.find(pdOpen);
    const std::size_t p1 = skeleton.find(pdClose, p0);
    const std::size_t a0 = skeleton.find(appended);
    UDVR_CHECK_MSG(
        p0 != std::string::npos && p1 != std::string::npos && a0 != std::string::npos &&
            skeleton.size() >= a0 + trailer.size() &&
            skeleton.compare(skeleton.size() - trailer.size(), trailer.size(), trailer) == 0,
        "VTK's model header is not as expected");
    const std::size_t lineStart = skeleton.rfind('\n', p0) + 1;
    const std::string indent(p0 - lineStart, ' ');
    const std::size_t fieldStart = a0 + appended.size();
    const std::size_t fieldBytes = skeleton.size() - trailer.size() - fieldStart;

    std::string header = skeleton.substr(0, p0);
    header += "<PointData Scalars=\"mean\">\n";
    std::uint64_t offset = fieldBytes;
    for (const Impl::Array& a : w.arrays) {
        header += indent + "  <DataArray type=\"Float32\" Name=\"" + a.name + "\"";
        if (a.components > 1)
            header += " NumberOfComponents=\"" + std::to_string(a.components) + "\"";
        header += " format=\"appended\"";
        header += reservedAttribute("RangeMin", vtkDouble(a.range[0]));
        header += reservedAttribute("RangeMax", vtkDouble(a.range[1]));
        header += reservedAttribute("offset", std::to_string(offset));
        header += "/>\n";
        offset += 8 * (3 + a.blockSizes.size()) + a.spillBytes;
    }
    header += indent + pdClose;
    header += skeleton.substr(p1 + pdClose.size(), fieldStart - (p1 + pdClose.size()));

    writeAtomically(w.path, [&](const fs::path& tmp) {
        const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (fd < 0)
            UDVR_FILE_FAIL("cannot write " << w.path.string() << ": " << writeErrorText(errno));
        struct Closer {
            int fd;
            ~Closer() {
                if (fd >= 0) ::close(fd);
            }
        } closer{fd};
        auto put = [&](const void* data, std::size_t size) {
            writeAll(fd, static_cast<const unsigned char*>(data), size, w.path);
        };
        put(header.data(), header.size());
        put(skeleton.data() + fieldStart, fieldBytes);
        std::vector<unsigned char> buf(std::size_t{4} << 20);
        for (const Impl::Array& a : w.arrays) {
            // vtkXMLWriter's compression header: blocks, block size, last block size, sizes.
            std::vector<std::uint64_t> words = {a.blockSizes.size(), w.blockSize,
                                                a.rawBytes % w.blockSize};
            words.insert(words.end(), a.blockSizes.begin(), a.blockSizes.end());
            put(words.data(), words.size() * sizeof(std::uint64_t));
            std::uint64_t left = a.spillBytes;
            for (off_t at = 0; left > 0;) {
                const ssize_t r =
                    ::pread(a.fd, buf.data(), std::min<std::uint64_t>(left, buf.size()), at);
                if (r < 0 && errno == EINTR) continue;
                if (r <= 0)
                    UDVR_FILE_FAIL("cannot write "
                                   << w.path.string() << ": reading back its " << a.name
                                   << " array: " << (r < 0 ? std::strerror(errno) : "short file"));
                put(buf.data(), static_cast<std::size_t>(r));
                at += r;
                left -= static_cast<std::uint64_t>(r);
            }
        }
        put(trailer.data(), trailer.size());
        closer.fd = -1;
        if (::close(fd) != 0)
            UDVR_FILE_FAIL("cannot write " << w.path.string() << ": " << writeErrorText(errno));
    });
    for (Impl::Array& a : w.arrays) {
        ::close(a.fd);
        a.fd = -1;
    }
}

}  // namespace udvr
