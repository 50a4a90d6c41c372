// "udvr Build Model" (issue 32, docs/paraview.md): a udvr model (SPEC §7 arrays and field data)
// from an ensemble whose members are the one-component point arrays of an image — `udvr build`
// over member files, with its --quantiles, --gmm and --density as properties. Every voxel's
// model depends on its own samples, its index in the whole grid (the GMM's random stream) and the
// whole ensemble's data range (the GMM's σ floor) only, so under MPI each rank builds its own
// piece of whole x-y planes, with the ranks' range reduced over MPI: `udvr build`'s model.
#ifndef vtkUdvrBuildModel_h
#define vtkUdvrBuildModel_h

#include "UdvrParaViewModule.h"  // for export macro
#include "vtkImageAlgorithm.h"

class UDVRPARAVIEW_EXPORT vtkUdvrBuildModel : public vtkImageAlgorithm {
  public:
    static vtkUdvrBuildModel* New();
    vtkTypeMacro(vtkUdvrBuildModel, vtkImageAlgorithm);
    void PrintSelf(ostream& os, vtkIndent indent) override;

    /// q quantiles (0 skips the quantiles array), `udvr build --quantiles`.
    vtkSetClampMacro(Quantiles, int, 0, 1024);
    vtkGetMacro(Quantiles, int);
    /// K GMM components (0 skips), `--gmm`; lowered to the member count when there are fewer.
    vtkSetClampMacro(GmmComponents, int, 0, 64);
    vtkGetMacro(GmmComponents, int);
    /// 0 empirical, 1 kde (Silverman's bandwidth), `--density`.
    vtkSetClampMacro(Density, int, 0, 1);
    vtkGetMacro(Density, int);

  protected:
    vtkUdvrBuildModel() = default;
    ~vtkUdvrBuildModel() override = default;
    /// The input of whole x-y planes over the z-range asked for: the piece's voxels then have
    /// consecutive indices in the whole grid, which the GMM's random streams are keyed by.
    int RequestUpdateExtent(vtkInformation*, vtkInformationVector**,
                            vtkInformationVector*) override;
    int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

    int Quantiles = 8;
    int GmmComponents = 4;
    int Density = 0;

  private:
    vtkUdvrBuildModel(const vtkUdvrBuildModel&) = delete;
    void operator=(const vtkUdvrBuildModel&) = delete;
};

#endif
