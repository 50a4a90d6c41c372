#include "vtkUdvrBuildModel.h"

#include <exception>
#include <string>
#include <variant>
#include <vector>

#include "udvr/stats/build_model.h"
#include "udvr/stats/model_field_data.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/check.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkStringArray.h"

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

int vtkUdvrBuildModel::RequestData(vtkInformation*, vtkInformationVector** inputVector,
                                   vtkInformationVector* outputVector) {
    vtkImageData* input = vtkImageData::GetData(inputVector[0]);
    vtkImageData* output = vtkImageData::GetData(outputVector);
    if (!input || !output) return 0;
    output->SetExtent(input->GetExtent());
    output->SetOrigin(input->GetOrigin());
    output->SetSpacing(input->GetSpacing());
    output->SetDirectionMatrix(input->GetDirectionMatrix());
    if (input->GetNumberOfPoints() == 0) return 1;  // a rank without data
    try {
        int ext[6], whole[6];
        input->GetExtent(ext);
        inputVector[0]->GetInformationObject(0)->Get(
            vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
        udvr::Ensemble e;
        const double* origin = input->GetOrigin();
        const double* spacing = input->GetSpacing();
        for (int a = 0; a < 3; ++a) {
            e.grid.dims[a] = ext[2 * a + 1] - ext[2 * a] + 1;
            e.grid.spacing[a] = spacing[a];
            e.grid.origin[a] = origin[a] + ext[2 * a] * spacing[a];
        }
        const std::size_t n = e.grid.pointCount();
        vtkPointData* pd = input->GetPointData();
        std::vector<vtkDataArray*> members;
        std::string names;
        for (int i = 0; i < pd->GetNumberOfArrays(); ++i) {
            vtkDataArray* a = pd->GetArray(i);
            if (a && a->GetNumberOfComponents() == 1 &&
                static_cast<std::size_t>(a->GetNumberOfTuples()) == n) {
                members.push_back(a);
                names +=
                    (names.empty() ? "" : ", ") + std::string(a->GetName() ? a->GetName() : "?");
            }
        }
        if (members.size() < 2)
            UDVR_FAIL(
                "an ensemble needs at least 2 members (one-component point arrays); the input has "
                << members.size());
        e.members = static_cast<int>(members.size());
        e.name = "ParaView point arrays";
        e.values.resize(n * members.size());
        for (std::size_t m = 0; m < members.size(); ++m)
            for (std::size_t v = 0; v < n; ++v)
                e.values[m * n + v] =
                    static_cast<float>(members[m]->GetComponent(static_cast<vtkIdType>(v), 0));

        udvr::BuildOptions o;
        o.quantiles = this->Quantiles;
        o.gmmComponents = this->GmmComponents;
        o.density =
            this->Density == 1 ? udvr::DensityEstimate::Kde : udvr::DensityEstimate::Empirical;
        o.bandwidthText = this->Density == 1 ? "silverman" : "";
        o.source = "ParaView point arrays " + names;
        udvr::fitBuildOptionsToSamples(o, e.members, false, false);  // as the CLI's defaults
        udvr::validateBuildOptions(o, e.members);
        udvr::ModelVolume model = udvr::buildModel(e, o);

        vtkPointData* out = output->GetPointData();
        for (const udvr::ModelFileArray& spec : udvr::kModelFileArrays) {
            const std::vector<float>& values = model.*spec.values;
            const int c = spec.floatsPerVoxel(model);
            if (values.empty() || c < 1) continue;
            vtkNew<vtkFloatArray> a;
            a->SetName(spec.name);
            a->SetNumberOfComponents(c);
            a->SetNumberOfTuples(static_cast<vtkIdType>(n));
            std::copy(values.begin(), values.end(), a->GetPointer(0));
            out->AddArray(a);
        }
        out->SetActiveScalars("mean");
        // Field data as `udvr build` writes it (SPEC §7); the bounds are the whole grid's. An
        // ensemble's build records no default_tf (the model's means are its basis), as the CLI's.
        for (int a = 0; a < 3; ++a) {
            model.bounds[2 * a] = origin[a] + whole[2 * a] * spacing[a];
            model.bounds[2 * a + 1] = origin[a] + whole[2 * a + 1] * spacing[a];
        }
        model.fullResMinSpacing = e.grid.minSpacing();
        model.downsample = 0;
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
}
