// udvr's ray caster as a VTK volume mapper inside ParaView (issue 32, docs/paraview.md): renders
// its vtkImageData input — a udvr model (SPEC §7 arrays) — with udvr_core at the ray samples
// (SPEC §4–5: classification after reconstruction), and draws the premultiplied image over what
// the renderer holds. The 1D TF is the volume property's colour and scalar-opacity functions
// (ParaView's lookup table and opacity editor); a 2D TF comes from a widget or raster file.
#ifndef vtkUdvrVolumeMapper_h
#define vtkUdvrVolumeMapper_h

#include "UdvrParaViewModule.h"  // for export macro
#include "vtkVolumeMapper.h"

class vtkImageData;

class UDVRPARAVIEW_EXPORT vtkUdvrVolumeMapper : public vtkVolumeMapper {
  public:
    static vtkUdvrVolumeMapper* New();
    vtkTypeMacro(vtkUdvrVolumeMapper, vtkVolumeMapper);
    void PrintSelf(ostream& os, vtkIndent indent) override;

    /// The model (udvr::ModelKind as an int; `udvr render --model`).
    vtkSetMacro(Model, int);
    vtkGetMacro(Model, int);
    /// Ray step and the TF's unit distance, world units; 0: SPEC §5's defaults.
    vtkSetMacro(Step, double);
    vtkGetMacro(Step, double);
    vtkSetMacro(UnitDistance, double);
    vtkGetMacro(UnitDistance, double);
    /// Early termination threshold (1 disables).
    vtkSetMacro(EarlyExit, double);
    vtkGetMacro(EarlyExit, double);
    /// gmm-mc realizations and seed.
    vtkSetMacro(Realizations, int);
    vtkGetMacro(Realizations, int);
    vtkSetMacro(Seed, int);
    vtkGetMacro(Seed, int);
    /// Model `uniform`: 0 variance-matched width (μ ± √3σ), 1 [min, max].
    vtkSetMacro(UniformWidth, int);
    vtkGetMacro(UniformWidth, int);
    /// A 2D TF file (widget JSON, .vti raster); empty: the 1D TF of the volume property.
    vtkSetStringMacro(TransferFunction2DFile);
    vtkGetStringMacro(TransferFunction2DFile);
    /// ParaView's own 2D TF (the representation's TransferFunction2D with UseTransfer2D and the
    /// gradient as y): its RGBA raster over range = (x0, x1, y0, y1); null: none. A file
    /// (TransferFunction2DFile) takes precedence.
    void SetParaViewTransferFunction2D(vtkImageData* raster, const double range[4]);

    /// The whole extent of the data this rank holds a piece of (the representation passes it).
    vtkSetVector6Macro(WholeExtent, int);
    vtkGetVector6Macro(WholeExtent, int);
    /// Wall time of udvr's last frame (ms), without drawing it.
    vtkGetMacro(LastFrameMilliseconds, double);

    void Render(vtkRenderer* ren, vtkVolume* vol) override;
    void ReleaseGraphicsResources(vtkWindow*) override {}

  protected:
    vtkUdvrVolumeMapper();
    ~vtkUdvrVolumeMapper() override;

    int Model = 0;
    double Step = 0.0;
    double UnitDistance = 0.0;
    double EarlyExit = 0.99;
    int Realizations = 200;
    int Seed = 1;
    int UniformWidth = 0;
    char* TransferFunction2DFile = nullptr;
    int WholeExtent[6] = {0, -1, 0, -1, 0, -1};
    double LastFrameMilliseconds = 0.0;

  private:
    struct Internals;
    Internals* Impl;
    vtkUdvrVolumeMapper(const vtkUdvrVolumeMapper&) = delete;
    void operator=(const vtkUdvrVolumeMapper&) = delete;
};

#endif
