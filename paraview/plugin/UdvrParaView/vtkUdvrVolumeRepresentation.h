// The "Uncertain Volume" representation (issue 32, docs/paraview.md): ParaView's image volume
// representation — data delivery, pieces per rank, ordered compositing, the lookup table and
// scalar opacity function — with udvr's ray caster (vtkUdvrVolumeMapper) as its mapper.
#ifndef vtkUdvrVolumeRepresentation_h
#define vtkUdvrVolumeRepresentation_h

#include "UdvrParaViewModule.h"  // for export macro
#include "vtkImageVolumeRepresentation.h"

class vtkUdvrVolumeMapper;

class UDVRPARAVIEW_EXPORT vtkUdvrVolumeRepresentation : public vtkImageVolumeRepresentation {
  public:
    static vtkUdvrVolumeRepresentation* New();
    vtkTypeMacro(vtkUdvrVolumeRepresentation, vtkImageVolumeRepresentation);
    void PrintSelf(ostream& os, vtkIndent indent) override;

    // The properties of udvr render (vtkUdvrVolumeMapper).
    void SetUncertainModel(int model);
    void SetUncertainStep(double step);
    void SetUncertainUnitDistance(double unit);
    void SetUncertainEarlyExit(double threshold);
    void SetUncertainRealizations(int realizations);
    void SetUncertainSeed(int seed);
    void SetUncertainUniformWidth(int minmax);
    void SetUncertainTransferFunction2D(const char* path);
    /// Wall time of the last frame udvr rendered on this rank (ms).
    double GetUncertainFrameMilliseconds();

  protected:
    vtkUdvrVolumeRepresentation();
    ~vtkUdvrVolumeRepresentation() override;
    void UpdateMapperParameters() override;
    vtkUdvrVolumeMapper* UdvrMapper();

  private:
    vtkUdvrVolumeRepresentation(const vtkUdvrVolumeRepresentation&) = delete;
    void operator=(const vtkUdvrVolumeRepresentation&) = delete;
};

#endif
