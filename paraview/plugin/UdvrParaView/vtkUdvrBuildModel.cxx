#include "vtkUdvrBuildModel.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <string>
#include <variant>
#include <vector>

#include "udvr/classify/tf_presets.h"
#include "udvr/stats/build_model.h"
#include "udvr/stats/model_field_data.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/check.h"
#include "udvr/util/text_parse.h"
#include "vtkCommunicator.h"
#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkStringArray.h"
#include "vtkType.h"

vtkStandardNewMacro(vtkUdvrBuildModel);

namespace {
// SPEC §7's field data of `model` (stats/model_field_data.h, the list udvr's own writers use) as
// VTK arrays of ParaView's VTK.
void addFieldData(vtkFieldData* fd, const udvr::ModelVolume& model) {
    for (const udvr::ModelFieldDatum& d :
         udvr::modelFieldData(model, model.hasQuantiles(), model.hasGmm())) {
        if (const int* i = std::get_if<int>(&d.value)) {
            vtkNew<vtkIntArray> a;
            a->SetName(d.name);
            a->InsertNextValue(*i);
            fd->AddArray(a);
        } else if (const auto* doubles = std::get_if<std::vector<double>>(&d.value)) {
            vtkNew<vtkDoubleArray> a;
            a->SetName(d.name);
            for (double v : *doubles) a->InsertNextValue(v);
            fd->AddArray(a);
        } else {
            vtkNew<vtkStringArray> a;
            a->SetName(d.name);
            a->InsertNextValue(std::get<std::string>(d.value));
            fd->AddArray(a);
        }
    }
}
}  // namespace

int vtkUdvrBuildModel::RequestInformation(vtkInformation*, vtkInformationVector** inputVector,
                                          vtkInformationVector* outputVector) {
    if (this->Downsample < 2) return 1;  // the input's grid (vtkImageAlgorithm copied it)
    vtkInformation* in = inputVector[0]->GetInformationObject(0);
    vtkInformation* out = outputVector->GetInformationObject(0);
    int whole[6];
    double origin[3], spacing[3];
    in->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
    in->Get(vtkDataObject::ORIGIN(), origin);
    in->Get(vtkDataObject::SPACING(), spacing);
    const int k = this->Downsample;
    int reduced[6];
    for (int a = 0; a < 3; ++a) {
        const int n = whole[2 * a + 1] - whole[2 * a] + 1;
        if (n < k) return 1;  // the input's grid; RequestData says why (udvr's message)
        // udvr::downsampledGrid: origin + (K−1)/2·spacing, spacing K·spacing.
        origin[a] += (whole[2 * a] + (k - 1) / 2.0) * spacing[a];
        spacing[a] *= k;
        reduced[2 * a] = 0;
        reduced[2 * a + 1] = n / k - 1;
    }
    out->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), reduced, 6);
    out->Set(vtkDataObject::ORIGIN(), origin, 3);
    out->Set(vtkDataObject::SPACING(), spacing, 3);
    out->Set(CAN_PRODUCE_SUB_EXTENT(), 1);
    return 1;
}

namespace {
// The model planes this process builds: its share of the output's whole extent in whole x-y
// planes, z split over the pieces asked for (UPDATE_PIECE_NUMBER of UPDATE_NUMBER_OF_PIECES:
// ParaView asks for pieces, one a rank), else the update extent's z.
void outputPiece(vtkInformation* out, int ext[6]) {
    int whole[6];
    out->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
    out->Get(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), ext);
    for (int i = 0; i < 4; ++i) ext[i] = whole[i];
    const int pieces = out->Has(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES())
                           ? out->Get(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES())
                           : 1;
    if (pieces <= 1) return;
    const int piece = out->Get(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER());
    // Split by cells, as ParaView's extent translator does: neighbouring pieces share their
    // boundary plane (built on both ranks, the same values), so a piece rendered straight from
    // the filter has the ghost plane trilinear reconstruction needs.
    const long long cells = std::max(whole[5] - whole[4], 0);
    ext[4] = whole[4] + static_cast<int>(cells * piece / pieces);
    ext[5] = whole[4] + static_cast<int>(cells * (piece + 1) / pieces);
}
}  // namespace

int vtkUdvrBuildModel::RequestUpdateExtent(vtkInformation*, vtkInformationVector** inputVector,
                                           vtkInformationVector* outputVector) {
    vtkInformation* in = inputVector[0]->GetInformationObject(0);
    vtkInformation* out = outputVector->GetInformationObject(0);
    int ext[6], whole[6];
    outputPiece(out, ext);
    in->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
    const int k = this->Downsample;
    const bool bricks = k >= 2 && whole[1] - whole[0] + 1 >= k && whole[3] - whole[2] + 1 >= k &&
                        whole[5] - whole[4] + 1 >= k;  // else RequestData's error
    if (ext[1] >= ext[0] && ext[3] >= ext[2] && ext[5] >= ext[4] && bricks) {
        // Model planes [z0, z1] are the input planes [K·z0, K·z1 + K); the last model plane
        // also asks for the trailing N mod K planes (which no brick uses): a single process
        // then holds the whole field, for the default TF's basis.
        const int z0 = ext[4], z1 = ext[5];
        for (int i = 0; i < 4; ++i) ext[i] = whole[i];
        ext[4] = whole[4] + z0 * k;
        ext[5] = whole[4] + (z1 + 1) * k - 1;
        if (z1 == (whole[5] - whole[4] + 1) / k - 1) ext[5] = whole[5];
    }
    // This extent of the input, not the input's own split into pieces.
    in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), ext, 6);
    in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER(), 0);
    in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES(), 1);
    in->Set(vtkStreamingDemandDrivenPipeline::EXACT_EXTENT(), 1);
    return 1;
}

namespace {
// The values of a VTK array as floats (udvr's samples are float32 whatever the file type).
void copyAsFloat(vtkDataArray* a, float* out) {
    const vtkIdType n = a->GetNumberOfTuples();
    for (vtkIdType t = 0; t < n; ++t) out[t] = static_cast<float>(a->GetComponent(t, 0));
}
// ScalarField::valueStep of an array: 1 for integer types, 0 for floating point.
double valueStepOf(vtkDataArray* a) {
    return a->GetDataType() == VTK_FLOAT || a->GetDataType() == VTK_DOUBLE ? 0.0 : 1.0;
}
}  // namespace

int vtkUdvrBuildModel::RequestData(vtkInformation*, vtkInformationVector** inputVector,
                                   vtkInformationVector* outputVector) {
    vtkImageData* input = vtkImageData::GetData(inputVector[0]);
    vtkImageData* output = vtkImageData::GetData(outputVector);
    if (!input || !output) return 0;
    const int k = this->Downsample >= 2 ? this->Downsample : 0;
    int ext[6], whole[6];
    input->GetExtent(ext);
    inputVector[0]->GetInformationObject(0)->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(),
                                                 whole);
    const double* origin = input->GetOrigin();
    const double* spacing = input->GetSpacing();
    // The samples: an ensemble of the one-component point arrays, or one array's K³ bricks.
    udvr::Ensemble e;
    udvr::ScalarField field;
    udvr::Grid3& grid = k ? field.grid : e.grid;
    for (int a = 0; a < 3; ++a) {
        grid.dims[a] = std::max(ext[2 * a + 1] - ext[2 * a] + 1, 0);
        grid.spacing[a] = spacing[a];
        grid.origin[a] = origin[a] + ext[2 * a] * spacing[a];
    }
    const std::size_t n = grid.pointCount();
    std::string failure, names;
    vtkPointData* pd = input->GetPointData();
    if (n > 0) {
        if (k) {
            // The Field property's array; where none is set (a proxy made before its input
            // had arrays), the input's only one-component point array.
            vtkDataArray* a = this->GetInputArrayToProcess(0, inputVector);
            if (!a) {
                for (int i = 0; i < pd->GetNumberOfArrays(); ++i) {
                    vtkDataArray* b = pd->GetArray(i);
                    if (!b || b->GetNumberOfComponents() != 1) continue;
                    if (a) {  // two candidates: the user has to choose
                        a = nullptr;
                        break;
                    }
                    a = b;
                }
            }
            if (!a || a->GetNumberOfComponents() != 1 ||
                static_cast<std::size_t>(a->GetNumberOfTuples()) != n)
                failure = "Downsample " + std::to_string(k) +
                          " models one one-component point array: choose it as Field (the input "
                          "has none selected, and not exactly one)";
            else {
                names = a->GetName() ? a->GetName() : "?";
                field.name = names;
                field.values.resize(n);
                copyAsFloat(a, field.values.data());
                field.valueStep = valueStepOf(a);
                field.valueType = a->GetDataTypeAsString();
            }
        } else {
            std::vector<vtkDataArray*> members;
            for (int i = 0; i < pd->GetNumberOfArrays(); ++i) {
                vtkDataArray* a = pd->GetArray(i);
                if (a && a->GetNumberOfComponents() == 1 &&
                    static_cast<std::size_t>(a->GetNumberOfTuples()) == n) {
                    members.push_back(a);
                    names += (names.empty() ? "" : ", ") +
                             std::string(a->GetName() ? a->GetName() : "?");
                }
            }
            if (members.size() < 2)
                failure =
                    "an ensemble needs at least 2 members (one-component point arrays); the "
                    "input has " +
                    std::to_string(members.size());
            else {
                e.members = static_cast<int>(members.size());
                e.name = "ParaView point arrays";
                e.values.resize(n * members.size());
                e.valueStep = valueStepOf(members[0]);
                e.valueType = members[0]->GetDataTypeAsString();
                for (std::size_t m = 0; m < members.size(); ++m) {
                    copyAsFloat(members[m], e.values.data() + m * n);
                    if (valueStepOf(members[m]) != e.valueStep ||
                        e.valueType != members[m]->GetDataTypeAsString()) {
                        e.valueStep = 0;
                        e.valueType = "mixed";
                    }
                }
            }
        }
    }
    // The whole input's data range (the GMM's σ floor): this piece's finite samples (for
    // bricks, those inside whole bricks, as build scans them), reduced over the MPI ranks —
    // before anything that may return, as every rank must take part.
    double range[2] = {std::numeric_limits<double>::infinity(),
                       -std::numeric_limits<double>::infinity()};
    auto widen = [&](float v) {
        if (!std::isfinite(v)) return;
        range[0] = std::min(range[0], static_cast<double>(v));
        range[1] = std::max(range[1], static_cast<double>(v));
    };
    if (k && !field.values.empty()) {
        const int used[3] = {grid.dims[0] / k * k, grid.dims[1] / k * k, grid.dims[2] / k * k};
        for (int z = 0; z < used[2]; ++z)
            for (int y = 0; y < used[1]; ++y)
                for (int x = 0; x < used[0]; ++x) widen(field.values[grid.index(x, y, z)]);
    } else {
        for (float v : e.values) widen(v);
    }
    vtkMultiProcessController* controller = vtkMultiProcessController::GetGlobalController();
    if (controller && controller->GetNumberOfProcesses() > 1) {
        double reduced[2];
        controller->AllReduce(&range[0], &reduced[0], 1, vtkCommunicator::MIN_OP);
        controller->AllReduce(&range[1], &reduced[1], 1, vtkCommunicator::MAX_OP);
        range[0] = reduced[0];
        range[1] = reduced[1];
    }
    if (n == 0) return 1;  // a rank without data
    if (!failure.empty()) {
        vtkErrorMacro(<< "udvr: " << failure);
        return 0;
    }
    try {
        // BuildOptions as `udvr build`'s buildOptionsOf makes them from the same flags.
        udvr::BuildOptions o;
        o.quantiles = this->Quantiles;
        if (!this->QuantileLevels.empty()) {
            o.quantileLevels = udvr::parseDoubleList(this->QuantileLevels, "QuantileLevels");
            o.quantiles = static_cast<int>(o.quantileLevels.size()) - 1;
        }
        o.gmmComponents = this->GmmComponents;
        o.nan = this->NanPolicy == 1 ? udvr::NanPolicy::Skip : udvr::NanPolicy::Error;
        o.density = this->Density < 0    ? udvr::defaultDensity(k > 0)
                    : this->Density == 1 ? udvr::DensityEstimate::Kde
                    : this->Density == 2 ? udvr::DensityEstimate::Dequantized
                                         : udvr::DensityEstimate::Empirical;
        o.bandwidthText = this->Bandwidth;
        if (o.density == udvr::DensityEstimate::Kde)
            o.bandwidth = udvr::parseBandwidth(this->Bandwidth);
        if (this->TailEps != 0.0) {
            if (!(this->TailEps > 0.0))
                UDVR_FAIL("TailEps " << this->TailEps
                                     << " is out of range; expected 0 < E < 0.5 (0: 1/(2n))");
            o.tailEps = this->TailEps;
        }
        udvr::validateBuildOptions(o, std::numeric_limits<int>::max());
        o.source = "ParaView point arrays " + names;
        if (k) o.source += " --downsample " + std::to_string(k);
        const long long samples = k ? static_cast<long long>(k) * k * k : e.members;
        udvr::fitBuildOptionsToSamples(o, samples, false, false);  // as the CLI's defaults
        // A piece of whole x-y planes (RequestUpdateExtent): its voxel 0's index in the whole
        // grid; with the whole range, the piece's values are the whole build's.
        const bool planes =
            ext[0] == whole[0] && ext[1] == whole[1] && ext[2] == whole[2] && ext[3] == whole[3];
        const bool wholeInput = planes && ext[4] == whole[4] && ext[5] == whole[5];
        if (planes) {
            const std::uint64_t plane = k ? static_cast<std::uint64_t>(grid.dims[0] / k) *
                                                static_cast<std::uint64_t>(grid.dims[1] / k)
                                          : static_cast<std::uint64_t>(grid.dims[0]) *
                                                static_cast<std::uint64_t>(grid.dims[1]);
            o.piece.firstVoxel =
                static_cast<std::uint64_t>((ext[4] - whole[4]) / (k ? k : 1)) * plane;
        } else {
            vtkWarningMacro(<< "udvr: the input is not whole x-y planes; the GMM's random "
                               "streams are this piece's, not the whole grid's");
        }
        if (range[0] <= range[1]) {
            o.piece.wholeMin = range[0];
            o.piece.wholeMax = range[1];
        }
        udvr::ModelVolume model =
            k ? udvr::buildModelDownsampled(field, k, o) : udvr::buildModel(e, o);

        const udvr::Grid3& g = model.grid;
        int outExt[6];
        for (int a = 0; a < 3; ++a) {
            const int first = k ? (ext[2 * a] - whole[2 * a]) / k : ext[2 * a];
            outExt[2 * a] = first;
            outExt[2 * a + 1] = first + g.dims[a] - 1;
        }
        output->SetExtent(outExt);
        output->SetSpacing(g.spacing.data());
        if (k) {  // the origin of extent 0 (RequestInformation's); exact for a whole input
            double outOrigin[3];
            for (int a = 0; a < 3; ++a) outOrigin[a] = g.origin[a] - outExt[2 * a] * g.spacing[a];
            output->SetOrigin(outOrigin);
        } else {
            output->SetOrigin(origin);
        }
        output->SetDirectionMatrix(input->GetDirectionMatrix());
        const std::size_t voxels = g.pointCount();
        vtkPointData* out = output->GetPointData();
        for (const udvr::ModelFileArray& spec : udvr::kModelFileArrays) {
            const std::vector<float>& values = model.*spec.values;
            const int c = spec.floatsPerVoxel(model);
            if (values.empty() || c < 1) continue;
            vtkNew<vtkFloatArray> a;
            a->SetName(spec.name);
            a->SetNumberOfComponents(c);
            a->SetNumberOfTuples(static_cast<vtkIdType>(voxels));
            std::copy(values.begin(), values.end(), a->GetPointer(0));
            out->AddArray(a);
        }
        out->SetActiveScalars("mean");
        // Field data as `udvr build` writes it (SPEC §7); the bounds are the whole input grid's.
        // An ensemble's build records no default_tf (the model's means are its basis), as the
        // CLI's; a brick build records the full-resolution field's where this process holds the
        // whole field without NaN/Inf (under MPI each rank holds a piece: none recorded).
        udvr::Grid3 full;
        for (int a = 0; a < 3; ++a) {
            full.dims[a] = whole[2 * a + 1] - whole[2 * a] + 1;
            full.spacing[a] = spacing[a];
            full.origin[a] = origin[a] + whole[2 * a] * spacing[a];
        }
        model.setFullResolution(full, k);
        if (k && wholeInput && std::all_of(field.values.begin(), field.values.end(), [](float v) {
                return std::isfinite(v);
            }))
            model.defaultTf =
                udvr::encodeDefaultTfBasis(udvr::defaultTfBasis(field.grid, field.values));
        else if (k)
            vtkWarningMacro(<< "udvr: the model records no default TF (it needs the whole "
                               "field on one process, without NaN/Inf)");
        addFieldData(output->GetFieldData(), model);
    } catch (const std::exception& ex) {
        vtkErrorMacro(<< "udvr: " << ex.what());
        return 0;
    }
    return 1;
}

void vtkUdvrBuildModel::PrintSelf(ostream& os, vtkIndent indent) {
    this->Superclass::PrintSelf(os, indent);
    os << indent << "Quantiles: " << this->Quantiles << "\n";
    os << indent << "GmmComponents: " << this->GmmComponents << "\n";
    os << indent << "Density: " << this->Density << "\n";
    os << indent << "Downsample: " << this->Downsample << "\n";
    os << indent << "Bandwidth: " << this->Bandwidth << "\n";
    os << indent << "TailEps: " << this->TailEps << "\n";
    os << indent << "QuantileLevels: " << this->QuantileLevels << "\n";
    os << indent << "NanPolicy: " << this->NanPolicy << "\n";
}
