/* gmsh_api.h: the functions of gmsh's C API (gmshc.h, gmsh 4.x) that gmsh_shim.c calls.
 *
 * gmsh_shim.c resolves them with dlsym() from the libgmsh it loads at run time, so the
 * build needs only their signatures, not gmsh itself: a package built where gmsh is not
 * installed (pip's isolated build environment, which holds only the build requirements)
 * still reads mesh files through the gmsh wheel installed beside it. Where meson finds
 * gmshc.h, gmsh_shim.c includes it before this file (DC_GMSHC_CHECK), and the compiler
 * refuses any signature here that differs from gmsh's own. */
#ifndef DC_GMSH_API_H
#define DC_GMSH_API_H

#include <stddef.h>

void gmshInitialize(int argc, char **argv, const int readConfigFiles, const int run,
                    int *ierr);
void gmshFinalize(int *ierr);
int gmshIsInitialized(int *ierr);
void gmshOptionSetNumber(const char *name, const double value, int *ierr);
void gmshOptionGetNumber(const char *name, double *value, int *ierr);
void gmshMerge(const char *fileName, int *ierr);
void gmshModelAdd(const char *name, int *ierr);
void gmshModelRemove(int *ierr);
void gmshModelGetCurrent(char **name, int *ierr);
void gmshModelSetCurrent(const char *name, int *ierr);
void gmshParserSetNumber(const char *name, const double *value, const size_t value_n,
                         int *ierr);
void gmshParserGetNames(char ***names, size_t *names_n, const char *search, int *ierr);
void gmshParserGetNumber(const char *name, double **value, size_t *value_n, int *ierr);
void gmshParserGetString(const char *name, char ***value, size_t *value_n, int *ierr);
void gmshParserSetString(const char *name, const char *const *value, const size_t value_n,
                         int *ierr);
void gmshOpen(const char *fileName, int *ierr);
void gmshParserClear(const char *name, int *ierr);
void gmshModelMeshGenerate(const int dim, int *ierr);
int gmshModelGetDimension(int *ierr);
void gmshModelMeshGetNodes(size_t **nodeTags, size_t *nodeTags_n, double **coord,
                           size_t *coord_n, double **parametricCoord,
                           size_t *parametricCoord_n, const int dim, const int tag,
                           const int includeBoundary, const int returnParametricCoord,
                           int *ierr);
void gmshModelGetEntities(int **dimTags, size_t *dimTags_n, const int dim, int *ierr);
void gmshModelMeshGetElements(int **elementTypes, size_t *elementTypes_n,
                              size_t ***elementTags, size_t **elementTags_n,
                              size_t *elementTags_nn, size_t ***nodeTags,
                              size_t **nodeTags_n, size_t *nodeTags_nn, const int dim,
                              const int tag, int *ierr);
void gmshModelGetPhysicalGroups(int **dimTags, size_t *dimTags_n, const int dim, int *ierr);
void gmshModelGetPhysicalName(const int dim, const int tag, char **name, int *ierr);
void gmshModelGetPhysicalGroupsForEntity(const int dim, const int tag, int **physicalTags,
                                         size_t *physicalTags_n, int *ierr);
void gmshFree(void *p);
void gmshLoggerGetLastError(char **error, int *ierr);
void gmshLoggerWrite(const char *message, const char *level, int *ierr);
/* optional: the estimate of a .geo's element count (gmsh_shim.c, geo_estimate) */
void gmshModelOccGetMass(const int dim, const int tag, double *mass, int *ierr);
void gmshModelGetBoundary(const int *dimTags, const size_t dimTags_n, int **outDimTags,
                          size_t *outDimTags_n, const int combined, const int oriented,
                          const int recursive, int *ierr);
void gmshModelGetParametrizationBounds(const int dim, const int tag, double **min,
                                       size_t *min_n, double **max, size_t *max_n,
                                       int *ierr);
void gmshModelGetValue(const int dim, const int tag, const double *parametricCoord,
                       const size_t parametricCoord_n, double **coord, size_t *coord_n,
                       int *ierr);
void gmshModelMeshGetSizes(const int *dimTags, const size_t dimTags_n, double **sizes,
                           size_t *sizes_n, int *ierr);
void gmshModelGetEntitiesForPhysicalGroup(const int dim, const int tag, int **tags,
                                          size_t *tags_n, int *ierr);
void gmshModelGetType(const int dim, const int tag, char **entityType, int *ierr);
void gmshOnelabClear(const char *name, int *ierr);
void gmshOnelabGet(char **data, const char *name, const char *format, int *ierr);
void gmshOnelabSet(const char *data, const char *format, int *ierr);

#endif
