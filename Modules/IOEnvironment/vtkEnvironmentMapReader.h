// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
/**
 * @class   vtkEnvironmentMapReader
 * @brief   Reads an HDR equirectangular environment map (OpenEXR, Radiance .hdr, ...).
 *
 * Reads linear radiance through OpenImageIO and produces a vtkImageData with a 3-component
 * float "Radiance" array, VTK's row order (j = 0 is the bottom row, the nadir), ready for
 * vtkPathTracedVolumeMapper::SetEnvironmentMapConnection(). Grey images are expanded to
 * RGB, an alpha channel is dropped. Negative texels (the undershoot of lossy EXR
 * compression) are clamped to zero and counted. NaN or infinite texels make the read fail;
 * with ReplaceNonFiniteValues on they are set to zero instead.
 */

#ifndef vtkEnvironmentMapReader_h
#define vtkEnvironmentMapReader_h

#include "holoIOEnvironmentModule.h" // For export macro
#include "vtkImageAlgorithm.h"

class HOLOIOENVIRONMENT_EXPORT vtkEnvironmentMapReader : public vtkImageAlgorithm
{
public:
  static vtkEnvironmentMapReader* New();
  vtkTypeMacro(vtkEnvironmentMapReader, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * The file to read.
   */
  vtkSetFilePathMacro(FileName);
  vtkGetFilePathMacro(FileName);
  ///@}

  ///@{
  /**
   * Replace NaN and infinite texels by zero (default off: they make the read fail).
   */
  vtkSetMacro(ReplaceNonFiniteValues, bool);
  vtkGetMacro(ReplaceNonFiniteValues, bool);
  vtkBooleanMacro(ReplaceNonFiniteValues, bool);
  ///@}

  ///@{
  /**
   * Non-finite values found, and negative values clamped to zero, by the last read.
   */
  vtkGetMacro(NumberOfInvalidValues, vtkIdType);
  vtkGetMacro(NumberOfClampedNegativeValues, vtkIdType);
  ///@}

protected:
  vtkEnvironmentMapReader();
  ~vtkEnvironmentMapReader() override;

  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  char* FileName = nullptr;
  bool ReplaceNonFiniteValues = false;
  vtkIdType NumberOfInvalidValues = 0;
  vtkIdType NumberOfClampedNegativeValues = 0;

private:
  vtkEnvironmentMapReader(const vtkEnvironmentMapReader&) = delete;
  void operator=(const vtkEnvironmentMapReader&) = delete;
};

#endif
