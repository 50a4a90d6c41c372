// VTK XML ImageData (.vti): scalar fields, 2D transfer functions and array lists (SPEC §7, §9);
// models in vti_model_io.cpp, the VTK plumbing in vtk_image.cpp.
#include <vtkDataArray.h>
#include <vtkDataObject.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>

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

// ---- fields ------------------------------------------------------------------------------------

ScalarField detail::readFieldVti(const fs::path& path, const std::string& var,
                                 std::string* geometryNote) {
    vtkSmartPointer<vtkImageData> image = readImageData(path);
    ScalarField f;
    f.grid = gridOf(path, image, geometryNote);
    vtkPointData* pd = image->GetPointData();
    vtkDataArray* array = nullptr;
    if (!var.empty()) {
        array = pd->GetArray(var.c_str());
        if (array == nullptr) {
            UDVR_FAIL(path.string()
                      << ": no point array '" << var << "' (arrays: " << arrayNames(pd) << ")");
        }
    } else {
        array = pd->GetScalars();
        if (array == nullptr && pd->GetNumberOfArrays() > 0) array = pd->GetArray(0);
        if (array == nullptr) UDVR_FAIL(path.string() << ": no numeric point data array");
    }
    std::string name = array->GetName() ? array->GetName() : "";
    if (array->GetNumberOfComponents() != 1) {
        UDVR_FAIL(path.string() << ": point array '" << name << "' has "
                                << array->GetNumberOfComponents()
                                << " components, expected a scalar (1 component)");
    }
    if (static_cast<std::size_t>(array->GetNumberOfTuples()) != f.grid.pointCount()) {
        UDVR_FAIL(path.string() << ": dims do not match the data: array '" << name << "' holds "
                                << array->GetNumberOfTuples() << " values, the grid "
                                << f.grid.pointCount());
    }
    f.values = toFloat(path, array);
    f.name = name;
    f.valueType = vtkTypeName(array->GetDataType());
    // Every numeric VTK type but these two holds integers.
    const bool floating = array->GetDataType() == VTK_FLOAT || array->GetDataType() == VTK_DOUBLE;
    f.valueStep = floating ? 0.0 : 1.0;
    return f;
}

void writeFieldVti(const fs::path& path, const ScalarField& field) {
    UDVR_CHECK_MSG(field.values.size() == field.grid.pointCount(), "field size vs grid");
    auto image = makeImage(field.grid);
    auto array = wrapFloats(field.values, 1, field.name.empty() ? "scalars" : field.name.c_str());
    image->GetPointData()->SetScalars(array);
    writeImageData(path, image);
}

// ---- 2D transfer functions (SPEC §9) -----------------------------------------------------------

TransferFunction2D detail::readTransferFunction2DVti(const fs::path& path) {
    vtkSmartPointer<vtkImageData> image =
        readImageData(path, static_cast<double>(kMaxTf2Resolution) * kMaxTf2Resolution);
    const std::string name = path.string();
    int extent[6];
    double origin[3], spacing[3];
    image->GetExtent(extent);
    image->GetOrigin(origin);
    image->GetSpacing(spacing);
    const int w = extent[1] - extent[0] + 1, h = extent[3] - extent[2] + 1;
    const int d = extent[5] - extent[4] + 1;
    if (d != 1 || w < 2 || h < 2)
        UDVR_FAIL(name << ": a 2D transfer function needs W x H x 1 points with W, H >= 2, got "
                       << w << "x" << h << "x" << d);
    for (int a = 0; a < 2; ++a)
        if (!(spacing[a] > 0.0) || !std::isfinite(spacing[a]) || !std::isfinite(origin[a]))
            UDVR_FAIL(name << ": spacing along " << (a == 0 ? "x" : "y") << " is " << spacing[a]
                           << " (origin " << origin[a] << "), expected a positive number");

    // The active scalars when they are RGBA, else the first 4-component point array.
    vtkPointData* pd = image->GetPointData();
    vtkDataArray* array = pd->GetScalars();
    if (array == nullptr || array->GetNumberOfComponents() != 4) {
        array = nullptr;
        for (int i = 0; i < pd->GetNumberOfArrays() && array == nullptr; ++i) {
            vtkDataArray* a = pd->GetArray(i);
            if (a != nullptr && a->GetNumberOfComponents() == 4) array = a;
        }
    }
    if (array == nullptr)
        UDVR_FAIL(name << ": no 4-component (r, g, b, alpha) point array (arrays: "
                       << arrayNames(pd) << ")");
    const std::string arrayName = array->GetName() ? array->GetName() : "";
    if (array->GetDataType() != VTK_FLOAT && array->GetDataType() != VTK_DOUBLE)
        UDVR_FAIL(name << ": point array '" << arrayName << "' is " << array->GetDataTypeAsString()
                       << ", expected float or double");
    if (static_cast<std::size_t>(array->GetNumberOfTuples()) != static_cast<std::size_t>(w) * h)
        UDVR_FAIL(name << ": dims do not match the data: array '" << arrayName << "' holds "
                       << array->GetNumberOfTuples() << " tuples, the grid " << w * h << " points");

    TransferFunction2D tf;
    tf.width = w;
    tf.height = h;
    tf.rgba = toFloat(path, array);
    for (std::size_t k = 0; k < tf.rgba.size(); ++k)
        if (!std::isfinite(tf.rgba[k]))
            UDVR_FAIL(name << ": non-finite value in array '" << arrayName << "' at point ("
                           << k / 4 % static_cast<std::size_t>(w) << ","
                           << k / 4 / static_cast<std::size_t>(w)
                           << "); expected values in [0, 1]");
    tf.x0 = origin[0] + extent[0] * spacing[0];
    tf.x1 = tf.x0 + (w - 1) * spacing[0];
    tf.y0 = origin[1] + extent[2] * spacing[1];
    tf.y1 = tf.y0 + (h - 1) * spacing[1];
    // udvr's own files also hold the exact domain (origin + (W−1)·spacing may differ from x1 in
    // the last bits); it is used only where it agrees with the geometry.
    const std::vector<double> exact = getDoubles(image->GetFieldData(), "tf2_domain");
    if (exact.size() == 4) {
        const double tolX = 1e-6 * spacing[0], tolY = 1e-6 * spacing[1];
        if (std::abs(exact[0] - tf.x0) <= tolX && std::abs(exact[1] - tf.x1) <= tolX &&
            std::abs(exact[2] - tf.y0) <= tolY && std::abs(exact[3] - tf.y1) <= tolY) {
            tf.x0 = exact[0];
            tf.x1 = exact[1];
            tf.y0 = exact[2];
            tf.y1 = exact[3];
        }
    }
    try {
        tf.validate();
    } catch (const UdvrError& e) {
        UDVR_FAIL(name << ": " << e.what());
    }
    return tf;
}

void writeTransferFunction2DVti(const fs::path& path, const TransferFunction2D& tf) {
    tf.validate();
    auto image = vtkSmartPointer<vtkImageData>::New();
    image->SetDimensions(tf.width, tf.height, 1);
    image->SetOrigin(tf.x0, tf.y0, 0.0);
    image->SetSpacing((tf.x1 - tf.x0) / (tf.width - 1), (tf.y1 - tf.y0) / (tf.height - 1), 1.0);
    image->GetPointData()->SetScalars(wrapFloats(tf.rgba, 4, "tf2"));
    addDouble(image->GetFieldData(), "tf2_domain", {tf.x0, tf.x1, tf.y0, tf.y1});
    writeImageData(path, image);
}

std::vector<ArrayInfo> detail::listArraysVti(const fs::path& path) {
    // The header only: the reader's pipeline information names each point array, its type and
    // components without reading the data (a model's arrays can be gigabytes).
    if (detail::lowerExtension(path) == ".pvti")  // the arrays of its first piece
        return listArraysVti(readPvtiHeader(path).pieces.front().file);
    vtkNew<ErrorCollector> errors;
    auto reader = newReader(path, errors);
    reader->UpdateInformation();
    throwIfFailed(path, reader, errors, false);
    vtkInformationVector* arraysInfo =
        reader->GetOutputInformation(0)->Get(vtkDataObject::POINT_DATA_VECTOR());
    std::vector<ArrayInfo> arrays;
    for (int i = 0; arraysInfo != nullptr && i < arraysInfo->GetNumberOfInformationObjects(); ++i) {
        vtkInformation* info = arraysInfo->GetInformationObject(i);
        ArrayInfo a;
        a.name = info->Has(vtkDataObject::FIELD_NAME()) ? info->Get(vtkDataObject::FIELD_NAME())
                                                        : "(unnamed)";
        a.components = info->Has(vtkDataObject::FIELD_NUMBER_OF_COMPONENTS())
                           ? info->Get(vtkDataObject::FIELD_NUMBER_OF_COMPONENTS())
                           : 1;
        const int type = info->Get(vtkDataObject::FIELD_ARRAY_TYPE());
        if (type == VTK_STRING) continue;  // not a numeric array
        a.type = vtkTypeName(type);
        arrays.push_back(a);
    }
    return arrays;
}

ModelVolume readModelOrField(const fs::path& given, const FieldReadOptions& options) {
    const fs::path path = singleFileOf(given);
    const std::string ext = detail::lowerExtension(path);
    if ((ext == ".vti" || ext == ".pvti") && options.var.empty()) {
        std::string modelError;
        try {
            std::string note;
            ModelVolume m = detail::readModelVti(path, &note);
            if (!m.mean.empty()) {
                detail::printNote(note);
                return m;
            }
            modelError = path.string() + " has no 'mean' array";
        } catch (const detail::ModelContentError&) {
            throw;  // a model, with impossible values: not a field either
        } catch (const UdvrError& e) {
            modelError = e.what();
        }
        try {
            return modelFromField(readField(path, options));
        } catch (const UdvrError& e) {
            // Both readers open the file the same way: a missing, truncated or corrupt file
            // fails both for one reason, which is said once (as the error it was: a FileError
            // stays one).
            if (modelError == e.what()) throw;
            UDVR_FAIL(path.string() << " is neither a model (" << modelError << ") nor a field ("
                                    << e.what() << ")");
        }
    }
    return modelFromField(readField(path, options));
}

}  // namespace udvr
