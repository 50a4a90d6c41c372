#include "vtkUdvrVolumeRepresentation.h"

#include "vtkObjectFactory.h"
#include "vtkPVTransferFunction2D.h"
#include "vtkUdvrVolumeMapper.h"

vtkStandardNewMacro(vtkUdvrVolumeRepresentation);

vtkUdvrVolumeRepresentation::vtkUdvrVolumeRepresentation() {
    this->VolumeMapper = vtkSmartPointer<vtkUdvrVolumeMapper>::New();
}

vtkUdvrVolumeRepresentation::~vtkUdvrVolumeRepresentation() = default;

vtkUdvrVolumeMapper* vtkUdvrVolumeRepresentation::UdvrMapper() {
    return static_cast<vtkUdvrVolumeMapper*>(this->VolumeMapper.GetPointer());
}

void vtkUdvrVolumeRepresentation::UpdateMapperParameters() {
    this->Superclass::UpdateMapperParameters();
    this->UdvrMapper()->SetWholeExtent(this->WholeExtent);
    // ParaView's own 2D TF editor (value x gradient magnitude): used where it is switched on.
    if (this->UseTransfer2D && this->UseGradientForTransfer2D && this->TransferFunction2D) {
        double range[4];
        this->TransferFunction2D->GetRange(range);
        this->UdvrMapper()->SetParaViewTransferFunction2D(this->TransferFunction2D->GetFunction(),
                                                          range);
    } else
        this->UdvrMapper()->SetParaViewTransferFunction2D(nullptr, nullptr);
}

void vtkUdvrVolumeRepresentation::SetUncertainModel(int model) {
    this->UdvrMapper()->SetModel(model);
}
void vtkUdvrVolumeRepresentation::SetUncertainStep(double step) {
    this->UdvrMapper()->SetStep(step);
}
void vtkUdvrVolumeRepresentation::SetUncertainUnitDistance(double unit) {
    this->UdvrMapper()->SetUnitDistance(unit);
}
void vtkUdvrVolumeRepresentation::SetUncertainEarlyExit(double threshold) {
    this->UdvrMapper()->SetEarlyExit(threshold);
}
void vtkUdvrVolumeRepresentation::SetUncertainRealizations(int realizations) {
    this->UdvrMapper()->SetRealizations(realizations);
}
void vtkUdvrVolumeRepresentation::SetUncertainSeed(int seed) { this->UdvrMapper()->SetSeed(seed); }
void vtkUdvrVolumeRepresentation::SetUncertainUniformWidth(int minmax) {
    this->UdvrMapper()->SetUniformWidth(minmax);
}
void vtkUdvrVolumeRepresentation::SetUncertainTransferFunction2D(const char* path) {
    this->UdvrMapper()->SetTransferFunction2DFile(path);
}
double vtkUdvrVolumeRepresentation::GetUncertainFrameMilliseconds() {
    return this->UdvrMapper()->GetLastFrameMilliseconds();
}

void vtkUdvrVolumeRepresentation::PrintSelf(ostream& os, vtkIndent indent) {
    this->Superclass::PrintSelf(os, indent);
}
